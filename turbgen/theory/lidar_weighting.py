"""Probe-volume weighting of a lidar along its beam, continuous and discrete.

Pulsed lidar: Gaussian of FWHM W_L (Guo et al. 2023, Eq. 27, 30; the extra |k.n| factor of Fu et al. 2023, Eq. 19 is a
misprint). Continuous-wave lidar: Lorentzian of Rayleigh length z_R (Fu et al. 2023, Eq. 14-16). The theory and the
virtual lidar both use the discrete weights (Fu et al. 2023, Sect. 2.3), so the frequency and time domains see the same
probe volume. Every function raises ParameterError for a width or length that is not a finite number > 0."""

from __future__ import annotations

import numpy as np

from turbgen.errors import check_positive

PULSED_HALF_WIDTH_FWHM = 1.5  # truncation of the Gaussian, in units of W_L
PULSED_STEP_M = 2.5
CW_HALF_WIDTH_ZR = 6.0  # truncation of the Lorentzian, in units of z_R
CW_STEP_ZR = 0.1


def sigma_from_fwhm_m(fwhm_m: float) -> float:
    """Standard deviation sigma_L = W_L / (2 sqrt(2 ln 2)) [m] of the pulsed weighting (Guo et al. 2023, Eq. 27)."""
    return check_positive("FWHM W_L (m)", fwhm_m) / (2.0 * np.sqrt(2.0 * np.log(2.0)))


def rayleigh_length_m(focus_distance_m, wavelength_m: float = 1.565e-6, beam_radius_m: float = 0.028):
    """Rayleigh length z_R = lambda f_d^2 / (pi r_b^2) of a continuous-wave lidar (Fu et al. 2023, Eq. 15): z_R [m]
    shaped like ``focus_distance_m`` f_d [m]; ``wavelength_m`` lambda and ``beam_radius_m`` r_b [m]."""
    check_positive("wavelength (m)", wavelength_m)
    check_positive("beam radius (m)", beam_radius_m)
    return wavelength_m * np.asarray(focus_distance_m, dtype=float) ** 2 / (np.pi * beam_radius_m**2)


def gaussian_weight(s_m, fwhm_m: float):
    """Pulsed weighting phi(s) = exp(-s^2 / (2 sigma_L^2)) / (sigma_L sqrt(2 pi)) [1/m] (Guo et al. 2023, Eq. 27);
    ``s_m`` [m] is the offset from the focus (array_like), ``fwhm_m`` the FWHM W_L [m]."""
    sig = sigma_from_fwhm_m(fwhm_m)
    s = np.asarray(s_m, dtype=float)
    return np.exp(-0.5 * (s / sig) ** 2) / (sig * np.sqrt(2.0 * np.pi))


def gaussian_transform(nu_rad_m, fwhm_m: float):
    """Fourier transform exp(-nu^2 sigma_L^2 / 2) [-] of the Gaussian weighting (Guo et al. 2023, Eq. 30); ``nu_rad_m``
    [rad/m] is the wavenumber along the beam (array_like), ``fwhm_m`` the FWHM W_L [m]."""
    sig = sigma_from_fwhm_m(fwhm_m)
    return np.exp(-0.5 * (np.asarray(nu_rad_m, dtype=float) * sig) ** 2)


def lorentzian_weight(s_m, z_r_m: float):
    """CW weighting phi(s) = z_R / (pi (z_R^2 + s^2)) [1/m] (Fu et al. 2023, Eq. 14); ``s_m`` [m] is the offset from the
    focus (array_like), ``z_r_m`` the Rayleigh length z_R [m]."""
    z = check_positive("Rayleigh length z_R (m)", z_r_m)
    s = np.asarray(s_m, dtype=float)
    return z / (np.pi * (z * z + s * s))


def lorentzian_transform(nu_rad_m, z_r_m: float):
    """Fourier transform exp(-|nu| z_R) [-] of the Lorentzian at ``nu_rad_m`` [rad/m] (Fu et al. 2023, Eq. 16)."""
    return np.exp(-np.abs(np.asarray(nu_rad_m, dtype=float)) * check_positive("z_R (m)", z_r_m))


def pulsed_discrete(fwhm_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(offsets [m], weights [-] summing to 1): Gaussian of FWHM ``fwhm_m`` [m] on [-1.5 W_L, 1.5 W_L], 2.5 m steps (Fu
    et al. 2023, Sect. 2.3)."""
    half = PULSED_HALF_WIDTH_FWHM * check_positive("FWHM W_L (m)", fwhm_m)
    n = int(np.floor(half / PULSED_STEP_M + 1e-9))
    s = PULSED_STEP_M * np.arange(-n, n + 1)
    w = gaussian_weight(s, fwhm_m)
    return s, w / w.sum()


def cw_discrete(z_r_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(offsets [m], weights [-] summing to 1), each (121,): Lorentzian of Rayleigh length ``z_r_m`` [m],
    on [-6 z_R, 6 z_R] in steps of 0.1 z_R (Fu et al. 2023, Sect. 2.3)."""
    z = check_positive("Rayleigh length z_R (m)", z_r_m)
    n = int(round(CW_HALF_WIDTH_ZR / CW_STEP_ZR))
    s = CW_STEP_ZR * z * np.arange(-n, n + 1)
    w = lorentzian_weight(s, z)
    return s, w / w.sum()


def discrete_transform(nu_rad_m, offsets_m, weights):
    """Transform sum_r w_r cos(nu s_r) [-] of symmetric discrete weights (= sum_r w_r exp(-i nu s_r)).

    ``nu_rad_m`` [rad/m] along the beam (the result has its shape); (K,) ``offsets_m`` s_r [m], symmetric about
    0, and ``weights`` w_r [-]."""
    nu = np.asarray(nu_rad_m, dtype=float)
    s = np.asarray(offsets_m, dtype=float)
    w = np.asarray(weights, dtype=float)
    return np.tensordot(np.cos(nu[..., None] * s), w, axes=([-1], [0]))
