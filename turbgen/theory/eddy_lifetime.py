"""Eddy lifetimes of the Mann model and of its space-time extension (Guo et al. 2023, Sect. 2.1, 2.3.1).

Vectorised over |k|; shear lifetimes are non-dimensional (tau~ = tau dU/dz / Gamma), the evolution
lifetime in seconds. Synthesis evaluates them on tens of millions of wavenumbers, so it uses the
cubic-spline tables (:class:`LifetimeTable`) instead."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.special import hyp2f1

from turbgen.theory.params import MannParams

# a = [2F1(1/3, 17/6; 4/3; -1)]^(-1/2) ≈ 1.23443 (Guo et al. 2023, Eq. 7)
GUO_A = float(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -1.0) ** -0.5)


def mann_lifetime(kL):
    """Mann lifetime tau~ = (kL)^(-2/3) [2F1(1/3,17/6;4/3;-(kL)^-2)]^(-1/2) [-] (Guo et al. 2023, Eq. 4) of
    ``kL`` = |k| L [-] (array_like); inf where kL <= 0."""
    kL = np.asarray(kL, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = kL ** (-2.0 / 3.0) / np.sqrt(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -(kL ** -2.0)))
    return np.where(kL > 0, out, np.inf)


def guo_lifetime(kL, factor1: float = 1.0):
    """Guo lifetime tau~ = a (kL)^b1 ((kL)^10 + 1)^((b2 - b1)/10) [-] (Guo et al. 2023, Eq. 6-7), b1 = -factor1,
    b2 = -2/3, of ``kL`` = |k| L [-]; evaluated in logarithms so large kL stays finite; inf where kL <= 0."""
    kL = np.asarray(kL, dtype=float)
    b1, b2 = -factor1, -2.0 / 3.0
    with np.errstate(divide="ignore", over="ignore"):
        log_kL = np.log(kL)
        log_tail = np.logaddexp(10.0 * log_kL, 0.0) * (b2 - b1) / 10.0
        out = GUO_A * np.exp(b1 * log_kL + log_tail)
    return np.where(kL > 0, out, np.inf)


def shear_distortion_beta(k, params: MannParams):
    """Non-dimensional distortion time beta(k) = Gamma tau~(kL) [-] (Guo et al. 2023, after Eq. 4), tau~ Eq. 4 or 6 per
    ``params.lifetime``; ``k`` is |k| [rad/m]. Zero everywhere for Gamma = 0 (isotropic: no distortion, also at k = 0),
    else inf at k = 0."""
    kL = np.asarray(k, dtype=float) * params.length_scale_m
    tau = mann_lifetime(kL) if params.lifetime == "mann" else guo_lifetime(kL, params.factor1)
    if params.gamma == 0.0:
        return np.zeros_like(tau)  # isotropic: no distortion, also where tau = inf (k = 0)
    return params.gamma * tau


def evolution_lifetime_s(k, params: MannParams):
    """Evolution lifetime tau_e(k) = gamma a (kL)^-1 ((kL)^10 + 1)^((1 - 2 factor2/3)/10) [s] (Guo et al. 2023, Eq. 15).
    gamma = ``params.evo_time_s``; factor2 = 3.5 gives the paper's exponent -2/15. ``k`` is |k| [rad/m]. Infinite for
    frozen parameters (evo_time_s None) and at k = 0."""
    kL = np.asarray(k, dtype=float) * params.length_scale_m
    if params.evo_time_s is None:
        return np.full_like(kL, np.inf)
    return _evolution_shape(kL, params.factor2, params.evo_time_s)


TABLE_KL_MIN, TABLE_KL_MAX = 1e-6, 1e6
TABLE_STEP = {"mann": 1.0 / 64.0, "guo": 1.0 / 64.0, "evolution": 1.0 / 128.0}  # grid steps in ln(kL)
TABLE_REL_ERROR = 1e-6  # bound on |tau_table / tau - 1| (tested)


def _evolution_shape(kL, factor2: float, gamma_s: float = 1.0):
    """tau_e of Eq. 15 for the evolution time ``gamma_s`` [s]; tau_e / gamma [-] for 1."""
    kL = np.asarray(kL, dtype=float)
    expo = (1.0 - 2.0 * factor2 / 3.0) / 10.0
    with np.errstate(divide="ignore", over="ignore"):
        log_kL = np.log(kL)
        out = gamma_s * GUO_A * np.exp(-log_kL + np.logaddexp(10.0 * log_kL, 0.0) * expo)
    return np.where(kL > 0, out, np.inf)


class LifetimeTable:
    """Not-a-knot cubic spline of tau~ over x = ln(kL) on a uniform grid (relative error <= TABLE_REL_ERROR).

    ``kind`` is "mann" (Guo et al. 2023, Eq. 4), "guo" (Eq. 6, ``parameter`` factor1) or "evolution" (Eq. 15
    over gamma, ``parameter`` factor2); else ValueError. The step TABLE_STEP[kind] bounds the error (5/384) h^4
    max|d^4 tau~/dx^4| / tau~, largest at the (kL)^10 knee (tests/theory/test_lifetime_table.py); outside
    [TABLE_KL_MIN, TABLE_KL_MAX] the exact function is evaluated. Interval i is [x0 + i h, x0 + (i + 1) h) with
    tau~ = ((c3 d + c2) d + c1) d + c0, d = x - x_i: ``coefficients`` (c3, c2, c1, c0), in the order the
    compiled stencil kernel and :meth:`from_ksq` evaluate it."""

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
        """tau~(|k| L) [-] (tau_e / gamma for "evolution") from ``ksq`` = |k|^2 [rad^2/m^2] (any shape) and L [m],
        float64 shaped like ``ksq``; exact outside the table's range, inf at k = 0."""
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
    """The cached :class:`LifetimeTable` of ``kind`` and ``parameter``."""
    return LifetimeTable(kind, parameter)


def shear_lifetime_table(params: MannParams) -> LifetimeTable:
    """The cached table of tau~ for beta = Gamma tau~(kL) of ``params`` (Guo et al. 2023, Eq. 4 or 6)."""
    return lifetime_table("mann") if params.lifetime == "mann" else lifetime_table("guo", float(params.factor1))


def evolution_lifetime_table(params: MannParams) -> LifetimeTable:
    """The cached table of tau_e / gamma [-] (Guo et al. 2023, Eq. 15; times evo_time_s for seconds)."""
    return lifetime_table("evolution", float(params.factor2))
