"""Not-a-knot cubic interpolating spline (de Boor 1978, "A Practical Guide to Splines", Ch. IV): the lifetime tables
of the generator and the validator's log-log interpolation of spectra.

The spline's values equal scipy.interpolate.CubicSpline's (its default not-a-knot end conditions and
extrapolation; tested bit for bit): the same equations for the slopes at the nodes, solved by the same banded LAPACK
solver, the same piecewise coefficients and the same evaluation order. It exists because importing
scipy.interpolate (with scipy.optimize, sparse and spatial, which it loads) took ~0.2 s of every `turbgen mann`
and `turbgen validate`; scipy.linalg, which is all this needs, takes ~0.05 s.
"""

from __future__ import annotations

import numpy as np


def not_a_knot_coefficients(x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients (c3, c2, c1, c0) of the not-a-knot cubic spline through (x, y).

    On interval i, s(t) = c3[i] d^3 + c2[i] d^2 + c1[i] d + c0[i] with d = t - x[i].

    Parameters
    ----------
    x : array_like
        Strictly increasing nodes (n,), n >= 4.
    y : array_like
        Values (n, ...) float64; trailing axes are interpolated independently.

    Returns
    -------
    tuple of numpy.ndarray
        c3, c2, c1, c0, each (n - 1, ...) float64.

    Raises
    ------
    ValueError
        If x is not strictly increasing, has fewer than 4 nodes, or y does not match it.
    """
    from scipy.linalg import solve_banded

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = x.size
    if x.ndim != 1 or n < 4 or y.shape[:1] != (n,):
        raise ValueError(f"a not-a-knot spline needs >= 4 nodes and one value per node (got {x.shape}, {y.shape})")
    dx = np.diff(x)
    if not np.all(dx > 0):
        raise ValueError("spline nodes must be strictly increasing")
    dxr = dx.reshape((n - 1,) + (1,) * (y.ndim - 1))
    slope = np.diff(y, axis=0) / dxr
    # slopes m_i at the nodes: dx_i m_{i-1} + 2 (dx_{i-1} + dx_i) m_i + dx_{i-1} m_{i+1}
    #                          = 3 (dx_i slope_{i-1} + dx_{i-1} slope_i), i = 1 .. n - 2 (de Boor, Eq. IV.7)
    bands = np.zeros((3, n))  # upper diagonal, diagonal, lower diagonal
    rhs = np.empty((n,) + y.shape[1:])
    bands[1, 1:-1] = 2 * (dx[:-1] + dx[1:])
    bands[0, 2:] = dx[:-1]
    bands[-1, :-2] = dx[1:]
    rhs[1:-1] = 3 * (dxr[1:] * slope[:-1] + dxr[:-1] * slope[1:])
    # not-a-knot: the third derivative is continuous at x_1 and x_{n-2}
    d = x[2] - x[0]
    bands[1, 0], bands[0, 1] = dx[1], d
    rhs[0] = ((dxr[0] + 2 * d) * dxr[1] * slope[0] + dxr[0] ** 2 * slope[1]) / d
    d = x[-1] - x[-3]
    bands[1, -1], bands[-1, -2] = dx[-2], d
    rhs[-1] = (dxr[-1] ** 2 * slope[-2] + (2 * d + dxr[-1]) * dxr[-2] * slope[-1]) / d
    m = solve_banded((1, 1), bands, rhs.reshape(n, -1), overwrite_ab=True, overwrite_b=True, check_finite=False)
    m = m.reshape(rhs.shape)
    # cubic Hermite pieces from the values and slopes at both ends of each interval
    t = (m[:-1] + m[1:] - 2 * slope) / dxr
    return t / dxr, (slope - m[:-1]) / dxr - t, m[:-1], y[:-1]


class NotAKnotSpline:
    """The not-a-knot cubic spline through (x, y), callable; extrapolated with the end pieces.

    Parameters
    ----------
    x : array_like
        Strictly increasing nodes (n,), n >= 4.
    y : array_like
        Values (n, ...).
    """

    def __init__(self, x, y):
        self.x = np.asarray(x, dtype=float)
        self.coefficients = not_a_knot_coefficients(self.x, y)

    def __call__(self, t) -> np.ndarray:
        """s(t) for any array ``t`` [units of x]: shape t.shape + y.shape[1:]."""
        t = np.asarray(t, dtype=float)
        i = np.clip(np.searchsorted(self.x, t, side="right") - 1, 0, self.x.size - 2)
        d = t - self.x[i]
        d = d.reshape(d.shape + (1,) * (self.coefficients[0].ndim - 1))
        c3, c2, c1, c0 = (c[i] for c in self.coefficients)
        d2 = d * d
        # ascending powers, each term added in turn (the order of scipy's piecewise-polynomial evaluation)
        return ((c0 + c1 * d) + c2 * d2) + c3 * (d2 * d)
