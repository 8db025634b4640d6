"""Space-time tensor and longitudinal coherence of Guo et al. (2022), as in Guo et al. (2023, Sect. 2.3.1).

tau_e depends on |k| only, so the (k2, k3) integral of Theta_11 at fixed k1 is the quadrature of
turbgen.theory.mann_quadrature with the radial factor exp(-dt / tau_e(sqrt(k1^2 + kappa^2)))."""

from __future__ import annotations

import numpy as np

from turbgen.errors import ParameterError, check_finite
from turbgen.theory.eddy_lifetime import evolution_lifetime_s
from turbgen.theory.mann_quadrature import perpendicular_quadrature
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import MannParams, check_wind_speed


def _decay(k, dt_s: float, params: MannParams):
    """exp(-|dt| / tau_e(k)); 1 for frozen turbulence or dt = 0."""
    tau = evolution_lifetime_s(k, params)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.isfinite(tau), np.exp(-abs(dt_s) / tau), 1.0)


def space_time_tensor(k1, k2, k3, dt_s: float, params: MannParams) -> np.ndarray:
    """``Theta_ij(k, dt) = exp(-|dt|/tau_e(k)) Phi_ij(k)`` [m^5 s^-2], (3, 3, ...) (Guo et al. 2023, Eq. 13).

    Parameters
    ----------
    k1, k2, k3, dt_s, params : array_like, array_like, array_like, float, MannParams
        Wavenumber components [rad/m] (broadcast together); time lag [s], finite; Mann model parameters (frozen
        turbulence: Theta = Phi).
    """
    dt = check_finite("dt (s)", dt_s)
    k1, k2, k3 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (k1, k2, k3)))
    k = np.sqrt(k1 * k1 + k2 * k2 + k3 * k3)
    return sheared_tensor(k1, k2, k3, params) * _decay(k, dt, params)


def longitudinal_coherence(f_hz, dx_m: float, U_m_s: float, params: MannParams) -> np.ndarray:
    """Magnitude-squared coherence of u between planes dx apart (Guo et al. 2023, Eq. 16).

    ``coh2(k1, dx) = |∫ Theta_11(k, dx/U) dk_perp|^2 / F11(k1)^2``, k1 = 2 pi f / U; 1 for frozen turbulence.

    Parameters
    ----------
    f_hz : array_like
        Frequencies [Hz], finite.
    dx_m, U_m_s, params : float, float, MannParams
        Longitudinal separation [m], mean wind speed [m/s] and Mann model.
    """
    f = np.atleast_1d(np.asarray(f_hz, dtype=float))
    if not np.all(np.isfinite(f)):
        raise ParameterError("f (Hz) must be finite numbers")
    U = check_wind_speed(U_m_s)
    dx = check_finite("dx (m)", dx_m)
    k1 = 2.0 * np.pi * f / U
    kappa, w, g = perpendicular_quadrature(k1, params, ((0, 0),))
    g11 = w * g[(0, 0)]
    decay = _decay(np.sqrt(k1[:, None] ** 2 + kappa**2), dx / U, params)
    ratio = (g11 * decay).sum(axis=-1) / g11.sum(axis=-1)
    return ratio * ratio
