"""The sheared Mann tensor (Mann 1994, Eq. 15-19) on the polar quadrature nodes of the (k2, k3) plane, compiled.

Two compiled loops do ``mann_tensor.sheared_tensor``'s arithmetic point by point in the same order (instead of
~40 whole-array passes over ~10^7 nodes); arctan, sqrt and E stay numpy calls between them (numpy's SIMD
versions round differently from the C library's), so every Phi_ij is bit-identical (tested)."""

from __future__ import annotations

import math

import numba
import numpy as np

from turbgen.theory.mann_tensor import von_karman_energy

_FOUR_PI = 4.0 * np.pi
# (i, j) pairs of the symmetric tensor -> a code per output row
PAIR_CODES = {(0, 0): 0, (1, 1): 1, (2, 2): 2, (0, 1): 3, (1, 0): 3, (0, 2): 4, (2, 0): 4, (1, 2): 5, (2, 1): 5}


@numba.njit(nogil=True, cache=True, inline="always")
def _node(k1, kappa, beta, cos_t, sin_t):
    """(k1, k2, beta, ksq, k30, k0sq, q) of one node, as mann_tensor._distortion forms them."""
    k2 = kappa * cos_t
    k3 = kappa * sin_t
    if k1 * k1 + k2 * k2 + k3 * k3 < 1e-60:  # |k| < 1e-30 rad/m: k = 0 (E ~ k^4 would underflow)
        k1 = k2 = k3 = 0.0
    ksq = k1 * k1 + k2 * k2 + k3 * k3
    if not math.isfinite(beta):
        beta = 0.0
    k30 = k3 + beta * k1
    k0sq = k1 * k1 + k2 * k2 + k30 * k30
    q = k1 * k1 + k2 * k2
    return k1, k2, beta, ksq, k30, k0sq, q


@numba.njit(nogil=True, cache=True, error_model="numpy")
def _arguments(k1, kappa, beta, cos_t, sin_t, k0sq_out, y_out, x_out):
    """k0^2 and the arguments of the arctan in zeta (Mann 1994 Eq. 16-17) at every node."""
    for r in range(kappa.shape[0]):
        for n in range(kappa.shape[1]):
            for t in range(cos_t.size):
                a1, a2, b, ksq, k30, k0sq, q = _node(k1[r], kappa[r, n], beta[r, n], cos_t[t], sin_t[t])
                k0sq_out[r, n, t] = k0sq
                y_out[r, n, t] = b * a1 * math.sqrt(q)
                x_out[r, n, t] = k0sq - k30 * a1 * b


@numba.njit(nogil=True, cache=True, error_model="numpy")
def _components(k1, kappa, beta, cos_t, sin_t, atan, e0, codes, out):
    """Phi_ij (rows of ``codes``, see PAIR_CODES) at every node from the arctan and E(k0) of each node."""
    for r in range(kappa.shape[0]):
        for n in range(kappa.shape[1]):
            for t in range(cos_t.size):
                a1, a2, b, ksq, k30, k0sq, q = _node(k1[r], kappa[r, n], beta[r, n], cos_t[t], sin_t[t])
                if q <= 1e-30 * ksq:  # on the k3 axis: zeta = 0
                    z1 = z2 = 0.0
                elif abs(a1) <= 1e-12 * math.sqrt(q):  # k1 -> 0 at fixed q
                    z1, z2 = -b, 0.0
                else:
                    sq = math.sqrt(q)
                    c1 = b * a1 * a1 * (k0sq - 2.0 * k30 * k30 + b * a1 * k30) / (ksq * q)
                    c2 = a2 * k0sq / (q * sq) * atan[r, n, t]
                    ratio = a2 / a1
                    z1 = c1 - ratio * c2
                    z2 = ratio * c1 + c2
                e = e0[r, n, t]
                fa = e / (_FOUR_PI * k0sq * k0sq) if k0sq > 0 else 0.0
                fb = e / (_FOUR_PI * k0sq * ksq) if ksq > 0 else 0.0
                fc = e / (_FOUR_PI * ksq * ksq) if ksq > 0 else 0.0
                for m in range(codes.size):
                    c = codes[m]
                    if c == 0:
                        v = fa * (k0sq - a1 * a1 - 2.0 * a1 * k30 * z1 + q * z1 * z1)
                    elif c == 1:
                        v = fa * (k0sq - a2 * a2 - 2.0 * a2 * k30 * z2 + q * z2 * z2)
                    elif c == 2:
                        v = fc * q
                    elif c == 3:
                        v = fa * (-a1 * a2 - a1 * k30 * z2 - a2 * k30 * z1 + q * z1 * z2)
                    elif c == 4:
                        v = fb * (-a1 * k30 + q * z1)
                    else:
                        v = fb * (-a2 * k30 + q * z2)
                    out[m, r, n, t] = v


def sheared_tensor_on_circles(k1, kappa, beta, cos_t, sin_t, pairs, ae: float, length_scale_m: float) -> np.ndarray:
    """(len(pairs), rows, nr, n_theta) Phi_ij(k1, kappa cos(theta), kappa sin(theta)) [m^5 s^-2] (Mann 1994 Eq. 19),
    bit for bit ``mann_tensor.sheared_tensor``'s: k1 (rows,) [rad/m], kappa and beta(|k|) (rows, nr) [rad/m], [-]
    (non-finite beta -> 0), the angles' cosines and sines (n_theta,), ae [m^(4/3) s^-2], L [m]."""
    k1, kappa, beta, cos_t, sin_t = (np.ascontiguousarray(a, dtype=np.float64) for a in (k1, kappa, beta, cos_t, sin_t))
    shape = kappa.shape + cos_t.shape
    k0sq, y, x = (np.empty(shape) for _ in range(3))
    _arguments(k1, kappa, beta, cos_t, sin_t, k0sq, y, x)
    atan = np.arctan2(y, x, out=y)
    np.sqrt(k0sq, out=x)
    e0 = von_karman_energy(x, ae, length_scale_m)
    codes = np.array([PAIR_CODES[tuple(p)] for p in pairs], dtype=np.int64)
    out = np.empty((codes.size, *shape))
    _components(k1, kappa, beta, cos_t, sin_t, atan, e0, codes, out)
    return out
