"""Rotor-effective wind speed (REWS, rotor-averaged u) auto-spectra (Guo et al. 2023, Sect. 3.1).

Mann:   S_RR(k1) = ∫ Phi_11(k) 4 J1^2(kappa R) / (kappa R)^2 dk_perp (Eq. 24), two-sided in k1.
Kaimal: S_RR(f) = S_1(f) / n_R^2 sum_i sum_j gamma_yz(dyz_ij, f) (Eq. 25), one-sided in f, with the
        un-squared IEC coherence exp(-a_yz r sqrt((f/U)^2 + (0.12/Lc)^2)).
"""

from __future__ import annotations

import numpy as np
from scipy.special import j1

from turbgen.errors import ParameterError, check_positive
from turbgen.theory.coherence_models import exponential_yz
from turbgen.theory.kaimal import kaimal_spectrum
from turbgen.theory.mann_quadrature import perpendicular_quadrature
from turbgen.theory.params import KaimalParams, MannParams, check_wind_speed


# Beyond z = kappa R = max(Z_SMOOTH, SMOOTH_S * s R), s = sqrt(k1^2 + L^-2), the filter is replaced by
# its local mean 4/(pi z^3) (J1^2 ~ 2 cos^2(z - 3pi/4)/(pi z)); the dropped oscillating part nearly
# cancels against the smooth integrand (measured: < 2e-5 relative change of S_RR against 200 / 16 s R).
Z_SMOOTH, SMOOTH_S = 60.0, 6.0


def _disk_filter(z, z_smooth=np.inf):
    """4 J1(z)^2 / z^2, the squared Fourier transform of the unit-disk average (-> 1 at z = 0),
    replaced by its mean 4/(pi z^3) beyond ``z_smooth``."""
    z = np.asarray(z, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(z < z_smooth, 4.0 * j1(z) ** 2 / (z * z), 4.0 / (np.pi * z**3))
    return np.where(z > 1e-8, out, 1.0)


def rews_spectrum_mann(k1, params: MannParams, radius_m: float) -> np.ndarray:
    """Two-sided REWS spectrum S_RR(k1) of the Mann model for a rotor of radius R (Guo et al. 2023, Eq. 24).

    S_RR(k1) = ∫ Phi_11(k) 4 J1^2(kappa R) / (kappa R)^2 dk_perp. The radial panels resolve the
    J1^2(kappa R) oscillation (narrower than pi/(2R)) up to kappa R = Z_SMOOTH (or SMOOTH_S s R if larger);
    beyond, the filter is replaced by its local mean.

    Parameters
    ----------
    k1 : array_like
        Longitudinal wavenumbers [rad/m], finite.
    params : MannParams
        Mann model parameters.
    radius_m : float
        Rotor radius R [m].

    Returns
    -------
    numpy.ndarray
        (len(k1),) S_RR [m^3 s^-2], two-sided in k1.

    Raises
    ------
    ParameterError
        If ``radius_m`` is not a finite number > 0 or ``k1`` is not finite numbers.
    """
    R = check_positive("radius (m)", radius_m)
    k1 = np.atleast_1d(np.asarray(k1, dtype=float))
    z_smooth = np.maximum(Z_SMOOTH, SMOOTH_S * np.sqrt(k1 * k1 + params.length_scale_m**-2) * R)
    kappa, w, g = perpendicular_quadrature(k1, params, ((0, 0),), resolve_m=2.0 * R, resolve_kappa_max=z_smooth / R)
    return (w * g[(0, 0)] * _disk_filter(kappa * R, z_smooth[:, None])).sum(axis=-1)


def rews_spectrum_kaimal(f_hz, kparams: KaimalParams, U_m_s: float, y_m, z_m) -> np.ndarray:
    """One-sided REWS spectrum of the Kaimal model over rotor points (y, z) (Guo et al. 2023, Eq. 25).

    S_RR(f) = S_1(f) / n_R^2 sum_i sum_j gamma_yz(dyz_ij, f), with the un-squared IEC coherence.

    Parameters
    ----------
    f_hz : array_like
        Frequencies [Hz].
    kparams : KaimalParams
        Kaimal spectra and IEC yz coherence parameters.
    U_m_s : float
        Mean wind speed U [m/s].
    y_m, z_m : array_like
        Lateral and vertical positions of the n_R rotor points [m], equally long.

    Returns
    -------
    numpy.ndarray
        (len(f),) S_RR [m^2 s^-2 Hz^-1], one-sided in f.

    Raises
    ------
    ParameterError
        If ``U_m_s`` is outside the allowed range, or ``y_m`` and ``z_m`` are empty, differ in length
        or hold non-finite values.
    """
    U = check_wind_speed(U_m_s)
    y = np.ravel(np.asarray(y_m, dtype=float))
    z = np.ravel(np.asarray(z_m, dtype=float))
    if y.size == 0 or y.shape != z.shape or not (np.all(np.isfinite(y)) and np.all(np.isfinite(z))):
        raise ParameterError("rotor points: y_m and z_m must be equally long lists of finite numbers")
    f = np.atleast_1d(np.asarray(f_hz, dtype=float))
    r = np.hypot(y[:, None] - y[None, :], z[:, None] - z[None, :])
    # the coherence depends on r only: sum over the distinct distances with their multiplicity
    r_unique, counts = np.unique(np.round(r, 9), return_counts=True)
    coh = exponential_yz(r_unique[None, :], f[:, None], U, kparams.a_yz, kparams.lc_m)
    s1 = kaimal_spectrum(f, kparams.sigma_m_s[0], kparams.length_scales_m[0], U)
    return s1 * (coh * counts).sum(axis=-1) / y.size**2
