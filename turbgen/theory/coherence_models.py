"""Coherence models as small plain functions (the pyconturb style).

All return the *un-squared* (magnitude) coherence, the correlation of the Fourier amplitudes that a
synthesis uses directly: square it to compare with a magnitude-squared estimate. Separations r, dx in
m (only |dx| counts), frequencies in Hz (broadcast against the separations), speeds in m/s."""

from __future__ import annotations

import numpy as np


def exponential_yz(r_m, f_hz, U_m_s: float, a_yz: float = 12.0, lc_m: float = 340.2):
    """Un-squared IEC yz coherence exp(-a_yz r sqrt((f/U)^2 + (0.12/Lc)^2)) (squared: Guo et al. 2023, Eq. 12).

    Parameters
    ----------
    r_m, f_hz : array_like
        Separation in the yz plane [m] and frequency [Hz]; the result [-] has their broadcast shape.
    U_m_s, a_yz, lc_m : float
        Mean wind speed [m/s]; coherence decrement [-] and scale parameter Lc = 8.1 Lambda_1 [m] (IEC 61400-1).
    """
    r = np.asarray(r_m, dtype=float)
    f = np.asarray(f_hz, dtype=float)
    return np.exp(-a_yz * r * np.sqrt((f / U_m_s) ** 2 + (0.12 / lc_m) ** 2))


def exponential_yz_decay_length_m(f_hz: float, U_m_s: float, a_yz: float = 12.0, lc_m: float = 340.2) -> float:
    """Decay length 1 / (a_yz kappa) [m] of :func:`exponential_yz` at ``f_hz``: coh(r) = exp(-r / decay),
    kappa = sqrt((f/U)^2 + (0.12/Lc)^2) [1/m]; infinite for a_yz = 0 (full coherence)."""
    kappa = np.hypot(f_hz / U_m_s, 0.12 / lc_m)
    return 1.0 / (a_yz * kappa) if a_yz > 0 else np.inf


def exponential_longitudinal(dx_m, f_hz, U_m_s: float, a_x: float, b_x: float):
    """Un-squared longitudinal coherence sqrt(exp(-a_x dx sqrt((f/U)^2 + b_x^2))) (squared: Guo et al. 2023, Eq. 18).

    Parameters
    ----------
    dx_m, f_hz : array_like
        Longitudinal separation [m] and frequency [Hz]; the result [-] has their broadcast shape.
    U_m_s, a_x, b_x : float
        Mean wind speed [m/s], decay parameter [-] and distance term [1/m].
    """
    dx = np.abs(np.asarray(dx_m, dtype=float))
    f = np.asarray(f_hz, dtype=float)
    return np.exp(-0.5 * a_x * dx * np.sqrt((f / U_m_s) ** 2 + b_x**2))


def simley_pao_parameters(sigma_total_m_s: float, U_m_s: float, length_u_m: float) -> tuple[float, float]:
    """(a_x [-], b_x [1/m]) of Guo et al. (2023) Eq. 18 from the LES fit of Simley & Pao (2015).

    a_x = 8.4 sigma_total / U + 0.05, b_x = 0.25 L_u^-1.24, with sigma_total = sqrt(s1^2 + s2^2 + s3^2)
    [m/s] and L_u = 8.1 Lambda1 [m]."""
    return 8.4 * sigma_total_m_s / U_m_s + 0.05, 0.25 * length_u_m**-1.24


def simley_pao(dx_m, f_hz, U_m_s: float, sigma_total_m_s: float, length_u_m: float):
    """Un-squared coherence of Eq. 18 (Guo et al. 2023) with :func:`simley_pao_parameters`."""
    a_x, b_x = simley_pao_parameters(sigma_total_m_s, U_m_s, length_u_m)
    return exponential_longitudinal(dx_m, f_hz, U_m_s, a_x, b_x)


def _kristensen_g(xi):
    """G(xi) = 33^(-2/3) (33 xi)^2 (33 xi + 3/11)^(1/2) / (33 xi + 1)^(11/6) (Kristensen 1979)."""
    x = 33.0 * xi
    return 33.0 ** (-2.0 / 3.0) * x**2 * np.sqrt(x + 3.0 / 11.0) / (x + 1.0) ** (11.0 / 6.0)


def kristensen(dx_m, f_hz, U_m_s: float, sigma_total_m_s: float, length_u_m: float):
    """Un-squared longitudinal coherence of Kristensen (1979).

    gamma^2 = exp(-2 alpha G(xi)) (1 - exp(-1/(2 alpha^m xi^2)))^2, xi = f L_u / U,
    alpha = sigma_total dx / (U L_u), m = 2 if alpha <= 1 else 1; dx = 0 or f = 0 give 1.
    ``sigma_total_m_s`` [m/s] and ``length_u_m`` [m] as :func:`simley_pao_parameters`."""
    dx = np.abs(np.asarray(dx_m, dtype=float))
    f = np.asarray(f_hz, dtype=float)
    xi = f * length_u_m / U_m_s
    alpha = sigma_total_m_s * dx / (U_m_s * length_u_m)
    m = np.where(alpha <= 1.0, 2.0, 1.0)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        tail = 1.0 - np.exp(-1.0 / (2.0 * alpha**m * xi**2))
        g = np.exp(-alpha * _kristensen_g(xi)) * tail
    # dx = 0 or f = 0: the limit is full coherence
    return np.where((alpha == 0) | (xi == 0), 1.0, g)


LONGITUDINAL_MODELS = {"exp": exponential_longitudinal, "simley-pao": simley_pao, "kristensen": kristensen}
