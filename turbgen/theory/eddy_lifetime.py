"""Eddy lifetimes of the Mann model and of its space-time extension (Guo et al. 2023, Sect. 2.1, 2.3.1).

All functions are vectorised over the wavenumber magnitude and return non-dimensional
lifetimes (tau * dU/dz / Gamma for the shear lifetimes) or seconds (evolution lifetime).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.special import hyp2f1

from turbgen.theory.params import MannParams

# a = [2F1(1/3, 17/6; 4/3; -1)]^(-1/2) ≈ 1.23443 (Guo et al. 2023, Eq. 7)
GUO_A = float(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -1.0) ** -0.5)


def mann_lifetime(kL):
    """Non-dimensional Mann lifetime (kL)^(-2/3) [2F1(1/3,17/6;4/3;-(kL)^-2)]^(-1/2) (Guo et al. 2023, Eq. 4).

    Parameters
    ----------
    kL : array_like
        Wavenumber magnitude times length scale, |k| L [-].

    Returns
    -------
    numpy.ndarray
        tau~ = tau dU/dz / Gamma [-], shaped like ``kL``; inf where kL <= 0.
    """
    kL = np.asarray(kL, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = kL ** (-2.0 / 3.0) / np.sqrt(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -(kL ** -2.0)))
    return np.where(kL > 0, out, np.inf)


def guo_lifetime(kL, factor1: float = 1.0):
    """Non-dimensional Guo lifetime a (kL)^b1 ((kL)^10 + 1)^((b2 - b1)/10), b1 = -factor1, b2 = -2/3 (Eq. 6).

    Guo et al. (2023), Eq. 6, with a = GUO_A (Eq. 7). Evaluated in logarithms so large kL stays finite.

    Parameters
    ----------
    kL : array_like
        Wavenumber magnitude times length scale, |k| L [-].
    factor1 : float, optional
        Small-k slope is -factor1 [-] (default 1).

    Returns
    -------
    numpy.ndarray
        tau~ = tau dU/dz / Gamma [-], shaped like ``kL``; inf where kL <= 0.
    """
    kL = np.asarray(kL, dtype=float)
    b1, b2 = -factor1, -2.0 / 3.0
    with np.errstate(divide="ignore", over="ignore"):
        # (kL)^10 overflows for kL > ~1e30; evaluate in logs so large kL stays finite.
        log_kL = np.log(kL)
        log_tail = np.logaddexp(10.0 * log_kL, 0.0) * (b2 - b1) / 10.0
        out = GUO_A * np.exp(b1 * log_kL + log_tail)
    return np.where(kL > 0, out, np.inf)


def shear_distortion_beta(k, params: MannParams):
    """beta(k) = Gamma * tau~(kL), the non-dimensional distortion time (Guo et al. (2023) after Eq. 4).

    tau~ is the Mann (Eq. 4) or Guo (Eq. 6) lifetime per ``params.lifetime``.

    Parameters
    ----------
    k : array_like
        Wavenumber magnitude |k| [rad/m].
    params : MannParams
        Mann model parameters (length_scale_m, gamma, lifetime, factor1 are used).

    Returns
    -------
    numpy.ndarray
        beta [-], shaped like ``k``; zero everywhere for Gamma = 0 (isotropic: no distortion, also
        where tau = inf at k = 0), else inf at k = 0.
    """
    kL = np.asarray(k, dtype=float) * params.length_scale_m
    if params.lifetime == "mann":
        tau = mann_lifetime(kL)
    else:
        tau = guo_lifetime(kL, params.factor1)
    if params.gamma == 0.0:
        return np.zeros_like(tau)  # isotropic: no distortion, also where tau = inf (k = 0)
    return params.gamma * tau


def evolution_lifetime_s(k, params: MannParams):
    """Evolution lifetime tau_e(k) [s] = gamma a (kL)^-1 ((kL)^10 + 1)^((1 - 2 factor2/3)/10) (Eq. 15).

    Guo et al. (2023), Eq. 15, with gamma = ``params.evo_time_s`` and a = GUO_A.
    factor2 = 3.5 gives the paper's exponent -2/15 (large-k slope -7/3).

    Parameters
    ----------
    k : array_like
        Wavenumber magnitude |k| [rad/m].
    params : MannParams
        Mann model parameters (length_scale_m, factor2, evo_time_s are used).

    Returns
    -------
    numpy.ndarray
        tau_e [s], shaped like ``k``. Infinite when the parameters are frozen (evo_time_s is None) or
        at k = 0.
    """
    kL = np.asarray(k, dtype=float) * params.length_scale_m
    if params.evo_time_s is None:
        return np.full_like(kL, np.inf)
    expo = (1.0 - 2.0 * params.factor2 / 3.0) / 10.0
    with np.errstate(divide="ignore", over="ignore"):
        log_kL = np.log(kL)
        out = params.evo_time_s * GUO_A * np.exp(-log_kL + np.logaddexp(10.0 * log_kL, 0.0) * expo)
    return np.where(kL > 0, out, np.inf)


# -- Tabulated lifetimes ------------------------------------------------------------------------------
# Every lifetime above depends on kL only. Synthesis evaluates them on tens of millions of wavenumbers
# (the hypergeometric function of Eq. 4 is costly per point), so it uses a not-a-knot cubic spline
# of tau~ against x = ln(kL) on a uniform grid of step h = TABLE_STEP[kind] instead. Its relative error is
# of order (5/384) h^4 max|d^4 tau~/dx^4| / tau~, largest for the lifetimes with the sharp (kL)^10
# knee (Eq. 6 and 15 with a large slope change). Measured on 2e6 random kL over the table's range for
# the Mann lifetime, the Guo lifetime with factor1 in [0.1, 3] and the evolution lifetime with factor2
# in [0.01, 10]: at most 1.4e-7 (h = 1/64 for Eq. 4 and 6, 1/128 for Eq. 15, whose factor2 = 10
# gives the sharpest knee: 2.6e-6 at h = 1/64); tests/theory/test_lifetime_table.py checks <= TABLE_REL_ERROR.
# Outside [TABLE_KL_MIN, TABLE_KL_MAX] the exact function is evaluated (kL < 1e-6 would need e.g. a
# 1e7 m long box at L = 1 m).
TABLE_KL_MIN, TABLE_KL_MAX = 1e-6, 1e6
TABLE_STEP = {"mann": 1.0 / 64.0, "guo": 1.0 / 64.0, "evolution": 1.0 / 128.0}  # grid steps in ln(kL)
TABLE_REL_ERROR = 1e-6  # documented bound on |tau_table / tau - 1| (tested)


def _evolution_shape(kL, factor2: float):
    """Non-dimensional evolution lifetime tau_e / gamma = a (kL)^-1 ((kL)^10 + 1)^((1 - 2 factor2/3)/10) (Eq. 15)."""
    kL = np.asarray(kL, dtype=float)
    expo = (1.0 - 2.0 * factor2 / 3.0) / 10.0
    with np.errstate(divide="ignore", over="ignore"):
        log_kL = np.log(kL)
        out = GUO_A * np.exp(-log_kL + np.logaddexp(10.0 * log_kL, 0.0) * expo)
    return np.where(kL > 0, out, np.inf)


class LifetimeTable:
    """Cubic spline of tau~ over x = ln(kL) on a uniform grid (accuracy: TABLE_REL_ERROR, see above).

    ``table.from_ksq(ksq, L)`` with |k|^2 [rad^2/m^2] and L [m] returns tau~(|k| L), float64, shaped
    like ``ksq`` (inf at k = 0). Outside [TABLE_KL_MIN, TABLE_KL_MAX] the exact function is evaluated.

    Parameters
    ----------
    kind : str
        "mann" (Guo et al. 2023, Eq. 4), "guo" (Eq. 6, ``parameter`` = factor1) or "evolution" (Eq. 15
        divided by gamma [s], ``parameter`` = factor2).
    parameter : float, optional
        factor1 or factor2 [-] (default 1; unused for "mann").

    Attributes
    ----------
    x0, h : float
        First node ln(TABLE_KL_MIN) and step of the grid in x = ln(kL) [-].
    n_intervals : int
        Intervals of the grid; interval i is [x0 + i h, x0 + (i + 1) h).
    coefficients : tuple of numpy.ndarray
        (c3, c2, c1, c0), each (n_intervals,) float64: tau~ = ((c3 d + c2) d + c1) d + c0 with d = x - x_i,
        evaluated in that order by from_ksq (and by the compiled stencil kernel, which must agree with it).
    exact : callable
        The exact function of kL, used outside the table's range.

    Raises
    ------
    ValueError
        If ``kind`` is not one of the three.
    """

    def __init__(self, kind: str, parameter: float = 1.0):
        if kind == "mann":
            self.exact = mann_lifetime
        elif kind == "guo":
            self.exact = lambda kL: guo_lifetime(kL, parameter)
        elif kind == "evolution":
            self.exact = lambda kL: _evolution_shape(kL, parameter)
        else:
            raise ValueError(f"unknown lifetime table kind {kind!r}")
        self.x0, self.h = float(np.log(TABLE_KL_MIN)), TABLE_STEP[kind]
        n = int(np.ceil((np.log(TABLE_KL_MAX) - self.x0) / self.h)) + 1
        x = self.x0 + self.h * np.arange(n)
        c = CubicSpline(x, self.exact(np.exp(x))).c  # not-a-knot; powers 3, 2, 1, 0 of (x - x_i), (n - 1,) each
        self.coefficients = tuple(np.ascontiguousarray(row) for row in c)  # (c3, c2, c1, c0) per interval
        self.n_intervals = n - 1

    def from_ksq(self, ksq, length_scale_m: float) -> np.ndarray:
        """tau~(|k| L) from |k|^2 (any shape); exact outside the table's range, inf at k = 0.

        Parameters
        ----------
        ksq : array_like
            Squared wavenumber magnitude |k|^2 [rad^2/m^2], any shape.
        length_scale_m : float
            Length scale L [m].

        Returns
        -------
        numpy.ndarray
            tau~ [-] (tau_e / gamma for kind "evolution"), float64, shaped like ``ksq``.
        """
        ksq = np.asarray(ksq, dtype=float)
        with np.errstate(divide="ignore"):
            x = np.log(ksq * (length_scale_m * length_scale_m))
        x *= 0.5 / self.h
        x -= self.x0 / self.h  # position in grid steps
        outside = ~((x >= 0) & (x < self.n_intervals))
        x[outside] = 0.0  # any in-table value; replaced by the exact function below
        idx = x.astype(np.intp)
        x -= idx
        x *= self.h  # x - x_i
        c3, c2, c1, c0 = self.coefficients
        out = np.take(c3, idx)
        out *= x
        out += np.take(c2, idx)
        out *= x
        out += np.take(c1, idx)
        out *= x
        out += np.take(c0, idx)
        if outside.any():
            out[outside] = self.exact(np.sqrt(ksq[outside]) * length_scale_m)
        return out


@lru_cache(maxsize=16)
def lifetime_table(kind: str, parameter: float = 1.0) -> LifetimeTable:
    """The (cached) LifetimeTable of ``kind`` and ``parameter`` (built in well under a second).

    Parameters
    ----------
    kind : str
        "mann", "guo" or "evolution" (see LifetimeTable).
    parameter : float, optional
        factor1 ("guo") or factor2 ("evolution") [-]; default 1.

    Returns
    -------
    LifetimeTable
        The table, shared between calls with the same arguments (lru_cache).

    Raises
    ------
    ValueError
        If ``kind`` is unknown.
    """
    return LifetimeTable(kind, parameter)


def shear_lifetime_table(params: MannParams) -> LifetimeTable:
    """The table of tau~ for beta = Gamma tau~(kL) of ``params`` (Eq. 4, or Eq. 6 with its factor1).

    Parameters
    ----------
    params : MannParams
        Mann model parameters (lifetime and factor1 are used).

    Returns
    -------
    LifetimeTable
        The cached table of the non-dimensional shear lifetime tau~ [-] (Guo et al. 2023, Eq. 4 or 6).
    """
    return lifetime_table("mann") if params.lifetime == "mann" else lifetime_table("guo", float(params.factor1))


def evolution_lifetime_table(params: MannParams) -> LifetimeTable:
    """The table of tau_e / gamma (Guo et al. 2023, Eq. 15 with ``params.factor2``).

    Parameters
    ----------
    params : MannParams
        Mann model parameters (factor2 is used).

    Returns
    -------
    LifetimeTable
        The cached table of tau_e / gamma [-]; multiply by gamma = evo_time_s for tau_e [s].
    """
    return lifetime_table("evolution", float(params.factor2))
