"""Eddy lifetimes of the Mann model and of its space-time extension (paper 000, Sect. 2.1, 2.3.1).

All functions are vectorised over the wavenumber magnitude and return non-dimensional
lifetimes (tau * dU/dz / Gamma for the shear lifetimes) or seconds (evolution lifetime).
"""

from __future__ import annotations

import numpy as np
from scipy.special import hyp2f1

from turbgen.theory.params import MannParams

# a = [2F1(1/3, 17/6; 4/3; -1)]^(-1/2) ≈ 1.23443 (paper 000 Eq. 7)
GUO_A = float(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -1.0) ** -0.5)


def mann_lifetime(kL):
    """Non-dimensional Mann lifetime (kL)^(-2/3) [2F1(1/3,17/6;4/3;-(kL)^-2)]^(-1/2) (paper 000 Eq. 4)."""
    kL = np.asarray(kL, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = kL ** (-2.0 / 3.0) / np.sqrt(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -(kL ** -2.0)))
    return np.where(kL > 0, out, np.inf)


def guo_lifetime(kL, factor1: float = 1.0):
    """Non-dimensional Guo lifetime a (kL)^b1 ((kL)^10 + 1)^((b2 - b1)/10), b1 = -factor1, b2 = -2/3 (Eq. 6)."""
    kL = np.asarray(kL, dtype=float)
    b1, b2 = -factor1, -2.0 / 3.0
    with np.errstate(divide="ignore", over="ignore"):
        # (kL)^10 overflows for kL > ~1e30; evaluate in logs so large kL stays finite.
        log_kL = np.log(kL)
        log_tail = np.logaddexp(10.0 * log_kL, 0.0) * (b2 - b1) / 10.0
        out = GUO_A * np.exp(b1 * log_kL + log_tail)
    return np.where(kL > 0, out, np.inf)


def shear_distortion_beta(k, params: MannParams):
    """beta(k) = Gamma * tau~(kL), the non-dimensional distortion time (paper 000 after Eq. 4)."""
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

    factor2 = 3.5 gives the paper's exponent -2/15 (large-k slope -7/3). Infinite when the
    parameters are frozen (evo_time_s is None) or at k = 0.
    """
    kL = np.asarray(k, dtype=float) * params.length_scale_m
    if params.evo_time_s is None:
        return np.full_like(kL, np.inf)
    expo = (1.0 - 2.0 * params.factor2 / 3.0) / 10.0
    with np.errstate(divide="ignore", over="ignore"):
        log_kL = np.log(kL)
        out = params.evo_time_s * GUO_A * np.exp(-log_kL + np.logaddexp(10.0 * log_kL, 0.0) * expo)
    return np.where(kL > 0, out, np.inf)
