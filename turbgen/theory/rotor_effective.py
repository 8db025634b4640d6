"""Rotor-effective wind speed (REWS, rotor-averaged u) auto-spectra (Guo et al. 2023, Sect. 3.1, Eq. 24-25)."""

from __future__ import annotations

import numpy as np
from scipy.special import j1

from turbgen.errors import ParameterError, check_positive
from turbgen.theory.coherence_models import exponential_yz
from turbgen.theory.kaimal import kaimal_spectrum
from turbgen.theory.mann_quadrature import perpendicular_quadrature
from turbgen.theory.params import KaimalParams, MannParams, check_wind_speed

Z_SMOOTH, SMOOTH_S = 60.0, 6.0


def _disk_filter(z, z_smooth=np.inf):
    """4 J1(z)^2 / z^2, the squared transform of the unit-disk average; its mean 4/(pi z^3) beyond ``z_smooth``."""
    z = np.asarray(z, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(z < z_smooth, 4.0 * j1(z) ** 2 / (z * z), 4.0 / (np.pi * z**3))
    return np.where(z > 1e-8, out, 1.0)


def rews_spectrum_mann(k1, params: MannParams, radius_m: float) -> np.ndarray:
    """Two-sided REWS spectrum S_RR(k1) [m^3 s^-2] of the Mann model, rotor radius R [m] (Guo et al. 2023, Eq. 24).

    S_RR(k1) = ∫ Phi_11(k) 4 J1^2(kappa R) / (kappa R)^2 dk_perp; the radial panels resolve the J1^2
    oscillation up to kappa R = max(Z_SMOOTH, SMOOTH_S s R), s = sqrt(k1^2 + L^-2), and beyond it the
    filter is its local mean (the dropped oscillating part nearly cancels)."""
    R = check_positive("radius (m)", radius_m)
    k1 = np.atleast_1d(np.asarray(k1, dtype=float))
    z_smooth = np.maximum(Z_SMOOTH, SMOOTH_S * np.sqrt(k1 * k1 + params.length_scale_m**-2) * R)
    kappa, w, g = perpendicular_quadrature(k1, params, ((0, 0),), resolve_m=2.0 * R, resolve_kappa_max=z_smooth / R)
    return (w * g[(0, 0)] * _disk_filter(kappa * R, z_smooth[:, None])).sum(axis=-1)


def rews_spectrum_kaimal(f_hz, kparams: KaimalParams, U_m_s: float, y_m, z_m, *, s1=None,
                         yz_coherence=None) -> np.ndarray:
    """One-sided REWS spectrum of the Kaimal model over rotor points (Guo et al. 2023, Eq. 25).

    S_RR(f) = S_1(f) / n_R^2 sum_i sum_j gamma_yz(dyz_ij, f), with the un-squared IEC coherence.

    Parameters
    ----------
    f_hz, kparams, U_m_s : array_like, KaimalParams, float
        Frequencies [Hz], Kaimal spectra with IEC yz coherence, mean wind speed [m/s].
    y_m, z_m : array_like
        Positions of the n_R rotor points [m], equally long and finite.
    s1, yz_coherence : array_like or callable, optional
        S_1 at ``f_hz`` [m^2/s] and ``yz_coherence(r_m, f_hz)`` [-] in place of the Kaimal u spectrum and IEC
        coherence (a store's user tables).

    Returns
    -------
    numpy.ndarray
        (len(f),) S_RR [m^2 s^-2 Hz^-1].
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
    if yz_coherence is None:
        coh = exponential_yz(r_unique[None, :], f[:, None], U, kparams.a_yz, kparams.lc_m)
    else:
        coh = np.broadcast_to(yz_coherence(r_unique[None, :], f[:, None]), (f.size, r_unique.size))
    s1 = kaimal_spectrum(f, kparams.sigma_m_s[0], kparams.length_scales_m[0], U) if s1 is None else s1
    return s1 * (coh * counts).sum(axis=-1) / y.size**2
