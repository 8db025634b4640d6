"""Compiled inner loop of the Mann synthesis: the OU step of the noise and u_hat = C n on a batch of k1 slabs.

Complex numbers are float32 (re, im) pairs following the numpy formulation's operations in order (same bits but
for the sign of some zeros). A row k2 < 0 reads the mirrored row (Z2 is odd in k2, the rest even)."""

from __future__ import annotations

import numba
import numpy as np

_ZERO = np.float32(0.0)
_ONE = np.float32(1.0)
_A, _P, _Z1, _Z2, _W, _RHO, _SIG = range(7)  # rows of the per-row factor scratch


@numba.njit(inline="always")
def _pairs(src, out, sign):
    """out[2 l] = out[2 l + 1] = sign src[l] (sign = +-1: exact)."""
    for l in range(src.shape[0]):
        out[2 * l] = sign * src[l]
        out[2 * l + 1] = sign * src[l]


@numba.njit(inline="always")
def _factors(coef, rho, sig, i, j, h, k1, k2, k3sq, evolve, z2_sign, w, out):
    """The factors of stored row h of slab i, duplicated per (re, im), into ``out`` (7, 2 nzp); Z2 times ``z2_sign``."""
    a, p = coef[0, j, h], coef[1, j, h]
    q = k1 * k1 + k2 * k2
    for l in range(w.shape[0]):
        den = a[l] * (q + k3sq[l])
        w[l] = (a[l] * a[l] * q + p[l] * p[l]) / den if den != _ZERO else _ZERO
    _pairs(a, out[_A], _ONE)
    _pairs(p, out[_P], _ONE)
    _pairs(coef[2, j, h], out[_Z1], _ONE)
    _pairs(coef[3, j, h], out[_Z2], z2_sign)
    _pairs(w, out[_W], _ONE)
    if evolve:
        _pairs(rho[i, h], out[_RHO], _ONE)
        _pairs(sig[i, h], out[_SIG], _ONE)


@numba.njit(inline="always")
def _product(n0, n1, n2, a, p, z1, z2, w, k1, k2, uu, uv, uw, x):
    """u_hat = C n at float x of a row: m = k2 n0 - k1 n1; u_w = W m; u_u = (P n1 - (A k2) n2) + Z1 m;
    u_v = ((A k1) n2 - P n0) + Z2 m (the operation order of the numpy formulation)."""
    m = n0 * k2 - n1 * k1
    uw[x] = w[x] * m
    uu[x] = (p[x] * n1 - (a[x] * k2) * n2) + z1[x] * m
    uv[x] = ((a[x] * k1) * n2 - p[x] * n0) + z2[x] * m


@numba.njit(inline="always")
def _evolve_row(n0, n1, n2, f0, f1, f2, fac, k1, k2, uu, uv, uw):
    """n <- rho n + sig fresh (in place), then u_hat = C n, on one row of floats."""
    rho, sig = fac[_RHO], fac[_SIG]
    for x in range(n0.shape[0]):
        a0 = n0[x] * rho[x] + f0[x] * sig[x]
        a1 = n1[x] * rho[x] + f1[x] * sig[x]
        a2 = n2[x] * rho[x] + f2[x] * sig[x]
        n0[x], n1[x], n2[x] = a0, a1, a2
        _product(a0, a1, a2, fac[_A], fac[_P], fac[_Z1], fac[_Z2], fac[_W], k1, k2, uu, uv, uw, x)


@numba.njit(inline="always")
def _frozen_row(n0, n1, n2, fac, k1, k2, uu, uv, uw):
    """u_hat = C n on one row of floats."""
    for x in range(n0.shape[0]):
        _product(n0[x], n1[x], n2[x], fac[_A], fac[_P], fac[_Z1], fac[_Z2], fac[_W], k1, k2, uu, uv, uw, x)


@numba.njit(nogil=True, cache=True)
def ou_product(n, fresh, rho, sig, coef, j0, k1, k2, k3sq, uhat, evolve):
    """OU step of the noise (Guo et al. 2023, Eq. 13-14) and u_hat = C n (Mann 1998, Eq. 46-47) on b slabs.

    ``n``, ``fresh``, ``uhat`` (b, 3, nyp, 2 nzp) float32 views of complex64; with ``evolve``, n <- rho n + sig fresh in
    place first. ``coef`` (4, slabs, nyp//2 + 1, nzp): A, Z1, Z2 [m^2/s], P [m/s]; k1, k2 [rad/m], k3sq [rad^2/m^2]."""
    nyp, nh = n.shape[2], coef.shape[2]
    fac = np.empty((7, n.shape[3]), np.float32)
    w = np.empty(coef.shape[3], np.float32)
    for i in range(n.shape[0]):
        for row in range(nyp):
            h = row if row < nh else nyp - row  # a row k2 < 0 reads the stored row of -k2
            _factors(coef, rho, sig, i, j0 + i, h, k1[i], k2[h], k3sq, evolve, _ONE if row == h else -_ONE, w, fac)
            uu, uv, uw = uhat[i, 0, row], uhat[i, 1, row], uhat[i, 2, row]
            if evolve:
                _evolve_row(n[i, 0, row], n[i, 1, row], n[i, 2, row], fresh[i, 0, row], fresh[i, 1, row],
                            fresh[i, 2, row], fac, k1[i], k2[row], uu, uv, uw)
            else:
                _frozen_row(n[i, 0, row], n[i, 1, row], n[i, 2, row], fac, k1[i], k2[row], uu, uv, uw)
