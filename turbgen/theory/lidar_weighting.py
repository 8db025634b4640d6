"""Probe-volume weighting of a lidar along its beam.

Pulsed lidar: Gaussian weighting with standard deviation sigma_L = W_L / (2 sqrt(2 ln 2)) (FWHM W_L),
phi(s) = exp(-s^2 / (2 sigma_L^2)) / (sigma_L sqrt(2 pi)), Fourier transform
phi_hat(nu) = exp(-nu^2 sigma_L^2 / 2) (Guo et al. 2023 Eq. 27, 30; the extra |k.n| factor printed in
Fu et al. 2023 Eq. 19 is a misprint).
Continuous-wave lidar: Lorentzian phi(s) = z_R / (pi (z_R^2 + s^2)), phi_hat(nu) = exp(-|nu| z_R), with
Rayleigh length z_R = lambda f_d^2 / (pi r_b^2) (Fu et al. 2023 Eq. 14-16).
Discrete forms (Fu et al. 2023 Sect. 2.3): pulsed s in [-1.5 W_L, 1.5 W_L] in steps of 2.5 m,
CW s in [-6 z_R, 6 z_R] in steps of 0.1 z_R, weights renormalised to sum 1. turbgen's theory and its
virtual lidar both use these discrete weights, so the frequency and time domains see the same
probe volume (the truncation drops ~10 % of the Lorentzian's weight, which matters for CW).
"""

from __future__ import annotations

import numpy as np

from turbgen.errors import check_positive

PULSED_HALF_WIDTH_FWHM = 1.5  # truncation of the Gaussian, in units of W_L
PULSED_STEP_M = 2.5
CW_HALF_WIDTH_ZR = 6.0  # truncation of the Lorentzian, in units of z_R
CW_STEP_ZR = 0.1


def sigma_from_fwhm_m(fwhm_m: float) -> float:
    """Standard deviation sigma_L = W_L / (2 sqrt(2 ln 2)) of the pulsed weighting (Guo et al. 2023 Eq. 27).

    Parameters
    ----------
    fwhm_m : float
        Full width at half maximum W_L [m].

    Returns
    -------
    float
        sigma_L [m].

    Raises
    ------
    ParameterError
        If ``fwhm_m`` is not a finite number > 0.
    """
    return check_positive("FWHM W_L (m)", fwhm_m) / (2.0 * np.sqrt(2.0 * np.log(2.0)))


def rayleigh_length_m(focus_distance_m, wavelength_m: float = 1.565e-6, beam_radius_m: float = 0.028):
    """Rayleigh length z_R = lambda f_d^2 / (pi r_b^2) of a continuous-wave lidar (Fu et al. 2023 Eq. 15).

    Parameters
    ----------
    focus_distance_m : array_like
        Focus distance f_d [m].
    wavelength_m : float, optional
        Laser wavelength lambda [m] (default 1.565e-6 m).
    beam_radius_m : float, optional
        Beam radius r_b [m] (default 0.028 m).

    Returns
    -------
    numpy.ndarray
        z_R [m], shaped like ``focus_distance_m``.

    Raises
    ------
    ParameterError
        If ``wavelength_m`` or ``beam_radius_m`` is not a finite number > 0.
    """
    check_positive("wavelength (m)", wavelength_m)
    check_positive("beam radius (m)", beam_radius_m)
    return wavelength_m * np.asarray(focus_distance_m, dtype=float) ** 2 / (np.pi * beam_radius_m**2)


def gaussian_weight(s_m, fwhm_m: float):
    """Continuous pulsed weighting phi(s) = exp(-s^2 / (2 sigma_L^2)) / (sigma_L sqrt(2 pi)) (Guo et al. 2023 Eq. 27).

    Parameters
    ----------
    s_m : array_like
        Position along the beam relative to the focus [m].
    fwhm_m : float
        Full width at half maximum W_L [m].

    Returns
    -------
    numpy.ndarray
        phi(s) [1/m], shaped like ``s_m``.

    Raises
    ------
    ParameterError
        If ``fwhm_m`` is not a finite number > 0.
    """
    sig = sigma_from_fwhm_m(fwhm_m)
    s = np.asarray(s_m, dtype=float)
    return np.exp(-0.5 * (s / sig) ** 2) / (sig * np.sqrt(2.0 * np.pi))


def gaussian_transform(nu_rad_m, fwhm_m: float):
    """Fourier transform of the Gaussian weighting, exp(-nu^2 sigma_L^2 / 2) (Guo et al. 2023 Eq. 30).

    Parameters
    ----------
    nu_rad_m : array_like
        Wavenumber along the beam nu [rad/m].
    fwhm_m : float
        Full width at half maximum W_L [m].

    Returns
    -------
    numpy.ndarray
        phi_hat(nu) [-] (1 at nu = 0), shaped like ``nu_rad_m``.

    Raises
    ------
    ParameterError
        If ``fwhm_m`` is not a finite number > 0.
    """
    sig = sigma_from_fwhm_m(fwhm_m)
    return np.exp(-0.5 * (np.asarray(nu_rad_m, dtype=float) * sig) ** 2)


def lorentzian_weight(s_m, z_r_m: float):
    """Continuous CW weighting phi(s) = z_R / (pi (z_R^2 + s^2)) (Fu et al. 2023 Eq. 14).

    Parameters
    ----------
    s_m : array_like
        Position along the beam relative to the focus [m].
    z_r_m : float
        Rayleigh length z_R [m].

    Returns
    -------
    numpy.ndarray
        phi(s) [1/m], shaped like ``s_m``.

    Raises
    ------
    ParameterError
        If ``z_r_m`` is not a finite number > 0.
    """
    z = check_positive("Rayleigh length z_R (m)", z_r_m)
    s = np.asarray(s_m, dtype=float)
    return z / (np.pi * (z * z + s * s))


def lorentzian_transform(nu_rad_m, z_r_m: float):
    """Fourier transform of the Lorentzian weighting, exp(-|nu| z_R) (Fu et al. 2023 Eq. 16).

    Parameters
    ----------
    nu_rad_m : array_like
        Wavenumber along the beam nu [rad/m].
    z_r_m : float
        Rayleigh length z_R [m].

    Returns
    -------
    numpy.ndarray
        phi_hat(nu) [-], shaped like ``nu_rad_m``.

    Raises
    ------
    ParameterError
        If ``z_r_m`` is not a finite number > 0.
    """
    return np.exp(-np.abs(np.asarray(nu_rad_m, dtype=float)) * check_positive("z_R (m)", z_r_m))


def pulsed_discrete(fwhm_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Truncated, discretised Gaussian (offsets [m], weights summing to 1) (Fu et al. 2023 Sect. 2.3).

    Offsets s in [-1.5 W_L, 1.5 W_L] in steps of 2.5 m.

    Parameters
    ----------
    fwhm_m : float
        Full width at half maximum W_L [m].

    Returns
    -------
    tuple of numpy.ndarray
        (offsets [m], weights [-]), each (2 n + 1,), the weights summing to 1.

    Raises
    ------
    ParameterError
        If ``fwhm_m`` is not a finite number > 0.
    """
    half = PULSED_HALF_WIDTH_FWHM * check_positive("FWHM W_L (m)", fwhm_m)
    n = int(np.floor(half / PULSED_STEP_M + 1e-9))
    s = PULSED_STEP_M * np.arange(-n, n + 1)
    w = gaussian_weight(s, fwhm_m)
    return s, w / w.sum()


def cw_discrete(z_r_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Truncated, discretised Lorentzian (offsets [m], weights summing to 1) (Fu et al. 2023 Sect. 2.3).

    Offsets s in [-6 z_R, 6 z_R] in steps of 0.1 z_R.

    Parameters
    ----------
    z_r_m : float
        Rayleigh length z_R [m].

    Returns
    -------
    tuple of numpy.ndarray
        (offsets [m], weights [-]), each (121,), the weights summing to 1.

    Raises
    ------
    ParameterError
        If ``z_r_m`` is not a finite number > 0.
    """
    z = check_positive("Rayleigh length z_R (m)", z_r_m)
    n = int(round(CW_HALF_WIDTH_ZR / CW_STEP_ZR))
    s = CW_STEP_ZR * z * np.arange(-n, n + 1)
    w = lorentzian_weight(s, z)
    return s, w / w.sum()


def discrete_transform(nu_rad_m, offsets_m, weights):
    """Transform of discrete weights: sum_r w_r exp(-i nu s_r) for symmetric weights, sum_r w_r cos(nu s_r).

    Parameters
    ----------
    nu_rad_m : array_like
        Wavenumber along the beam nu [rad/m], any shape.
    offsets_m : array_like
        (K,) offsets s_r along the beam [m], symmetric about 0.
    weights : array_like
        (K,) weights w_r [-].

    Returns
    -------
    numpy.ndarray
        Real transform [-], shaped like ``nu_rad_m``.
    """
    nu = np.asarray(nu_rad_m, dtype=float)
    s = np.asarray(offsets_m, dtype=float)
    w = np.asarray(weights, dtype=float)
    return np.tensordot(np.cos(nu[..., None] * s), w, axes=([-1], [0]))
