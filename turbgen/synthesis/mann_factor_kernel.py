"""Compiled per-point loops of the Mann stencil (turbgen.synthesis.mann_stencil): lifetimes and compact factors.

They evaluate the float64 operations of the numpy reference (tests/synthesis/stencil_reference.py) in the same
order; log, exp and arctan stay numpy ufuncs between the loops, which round as the reference does."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(nogil=True, cache=True, error_model="numpy")
def squared_wavenumbers(k1, k2, k3, factor, out):
    """``out[i, j, l]`` = ((k1[i]^2 + k2[j]^2) + k3[l]^2) ``factor``: |k|^2 times ``factor`` on slabs x rows x columns."""
    for i in range(k1.size):
        for j in range(k2.size):
            q = k1[i] * k1[i] + k2[j] * k2[j]
            for l in range(k3.size):
                out[i, j, l] = (q + k3[l] * k3[l]) * factor


@numba.njit(nogil=True, cache=True, error_model="numpy")
def table_spline(log_kl_sq, inv_2h, x0_h, step, n_intervals, c3, c2, c1, c0, out):
    """The lifetime table's spline at ln(|k|^2 L^2), as LifetimeTable.from_ksq; nan outside the table (k = 0 too);
    returns the number of points outside the range."""
    xs = log_kl_sq.reshape(-1)
    values = out.reshape(-1)
    outside = 0
    for n in range(xs.size):
        x = xs[n] * inv_2h
        x -= x0_h
        if not (x >= 0.0 and x < n_intervals):
            values[n] = np.nan
            outside += 1
            continue
        idx = int(x)
        x -= idx
        x *= step
        v = c3[idx]
        v *= x
        v += c2[idx]
        v *= x
        v += c1[idx]
        v *= x
        v += c0[idx]
        values[n] = v
    return outside


@numba.njit(nogil=True, cache=True, error_model="numpy")
def transcendental_arguments(k1, k2, k3, beta_half, length_sq, e_arg, t_arg):
    """The arguments 1 + k0^2 L^2 (of e) and beta k1 sqrt(q) / (k0^2 - k30 beta k1) (arctan in zeta2, Mann 1994
    Eq. 16) on slabs x rows x columns; ``beta_half`` on the columns k3 >= 0 (|k|^2 is even in k3)."""
    nzp = k3.size
    h = nzp // 2
    for i in range(k1.size):
        kk1 = k1[i]
        for j in range(k2.size):
            q = kk1 * kk1 + k2[j] * k2[j]
            sq = math.sqrt(q)
            for part in range(2):  # columns k3 >= 0 (and the Nyquist), then k3 < 0: see mann_factors
                for l in range(0 if part == 0 else h + 1, h + 1 if part == 0 else nzp):
                    bk1 = beta_half[i, j, l if part == 0 else nzp - l] * kk1
                    k30 = bk1 + k3[l]
                    k0sq = k30 * k30 + q
                    e_arg[i, j, l] = k0sq * length_sq + 1.0
                    t_arg[i, j, l] = (bk1 * sq) / (k0sq - k30 * bk1)


@numba.njit(nogil=True, cache=True, error_model="numpy")
def mann_factors(k1, k2, k3, beta_half, inv_tau_half, e, arctan, unit, energy, scale, f0, f1, f2, f3, inv_tau):
    """The compact factors of slabs x rows x columns into f0 .. f3: unit (e, k30, c1, c2) float64, else
    (A, P, Z1, Z2) as mann_factors.apply_energy forms them; 1/tau_e [1/s] mirrored into a non-empty ``inv_tau``."""
    nzp = k3.size
    h = nzp // 2
    with_tau = inv_tau.size > 0
    for i in range(k1.size):
        kk1 = k1[i]
        for j in range(k2.size):
            kk2 = k2[j]
            q = kk1 * kk1 + kk2 * kk2
            w = kk2 / (q * math.sqrt(q))
            ratio = kk2 / kk1
            # the columns k3 >= 0 (and the Nyquist), then k3 < 0, each read from beta_half in one direction: a loop
            # the compiler vectorises (one loop with the mirrored column index did not; same bits either way)
            for part in range(2):
                for l in range(0 if part == 0 else h + 1, h + 1 if part == 0 else nzp):
                    lc = l if part == 0 else nzp - l
                    kk3 = k3[l]
                    ksq = q + kk3 * kk3
                    beta = beta_half[i, j, lc]
                    bk1 = beta * kk1
                    k30 = bk1 + kk3
                    k0sq = k30 * k30 + q
                    ee = e[i, j, l]
                    # zeta1 = C1 - (k2/k1) C2, zeta2 = (k2/k1) C1 + C2 of Mann (1994) Eq. 13-17
                    # (mann_factors.slab_factors)
                    c1 = bk1 * k30 - 2.0 * k30 * k30
                    c1 = (c1 + k0sq) * (bk1 * kk1) / (ksq * q)
                    c2 = arctan[i, j, l]
                    # atan2(Y, X) with Y = beta k1 sqrt(q) <= 0 (stored k1 <= 0, beta >= 0): arctan(Y / X), minus pi
                    # where X < 0 (the continuous branch of Mann 1994 Eq. 16)
                    if k0sq - k30 * bk1 < 0.0:
                        c2 -= math.pi
                    c2 = c2 * k0sq * w
                    z1 = c1 - c2 * ratio
                    z2 = c2 + c1 * ratio
                    if kk1 == 0.0:  # the k1 -> 0 limit: zeta1 = -beta, zeta2 = 0; zeta = 0 on the k3 axis; k = 0 empty
                        z1 = -beta
                        z2 = 0.0
                        if q == 0.0:
                            z1 = 0.0
                        if ksq == 0.0:
                            ee = 0.0
                            k30 = 0.0
                            z1 = 0.0
                            z2 = 0.0
                    if unit:
                        f0[i, j, l] = ee
                        f1[i, j, l] = k30
                        f2[i, j, l] = z1
                        f3[i, j, l] = z2
                    else:
                        a = ee * energy
                        p = k30 * a
                        z1 = z1 * a
                        z2 = z2 * a
                        if kk1 == 0.0 and j == 0:  # row 0: k2 = 0
                            a = 0.0
                        f0[i, j, l] = a * scale
                        f1[i, j, l] = p * scale
                        f2[i, j, l] = z1 * scale
                        f3[i, j, l] = z2 * scale
                    if with_tau:
                        inv_tau[i, j, l] = inv_tau_half[i, j, lc]
