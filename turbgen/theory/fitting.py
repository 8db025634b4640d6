"""Kaimal / exponential-coherence models fitted to the Mann space-time model (Guo et al. 2023, Sect. 2.4).

The paper does not state its frequency grids; the defaults below are documented in the README. Fit
frequencies must be at least 3 finite values > 0 and U inside turbgen.theory.ranges (else ParameterError)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares, minimize_scalar

from turbgen.errors import ParameterError, check_finite, check_positive
from turbgen.theory.coherence_models import exponential_yz
from turbgen.theory.kaimal import kaimal_spectrum
from turbgen.theory.mann_spectra import one_point_spectra, yz_coherence
from turbgen.theory.params import MannParams, check_wind_speed
from turbgen.theory.space_time import longitudinal_coherence

SPECTRA_F_HZ = np.arange(1, 1001) * 1e-3
YZ_F_HZ = np.logspace(-3, 0, 40)
LONG_F_HZ = np.logspace(np.log10(3e-4), np.log10(0.5), 60)


def _grid(f_hz, default) -> np.ndarray:
    f = np.atleast_1d(np.asarray(default if f_hz is None else f_hz, dtype=float))
    if f.size < 3 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise ParameterError("fit frequencies (Hz) must be at least 3 finite values > 0")
    return f


def fit_kaimal_spectra(params: MannParams, U_m_s: float, f_hz=None) -> dict:
    """Kaimal (sigma_i [m/s], L_i [m]) per component fitted to the Mann spectra (Guo et al. 2023, Eq. 20).

    Minimises sum_n (1/k1_n) (S_i(f_n) f_n - 2 F_ii(k1_n) k1_n)^2, k1 = 2 pi f / U: for each L_i the best
    sigma_i^2 is linear least squares, L_i a bounded search in ln L (0.1 m to 1e5 m). On the default linear
    grid the 1/k1 weights give every logarithmic band the same weight ("equivalent weighting", after Eq. 21).

    Parameters
    ----------
    params, U_m_s : MannParams, float
        Mann model and mean wind speed [m/s].
    f_hz : array_like, optional
        Fit frequencies [Hz]; default SPECTRA_F_HZ (1 mHz to 1 Hz, linear).

    Returns
    -------
    dict
        {"sigma_m_s": (s1, s2, s3) [m/s], "length_scales_m": (L1, L2, L3) [m], "f_hz": grid [Hz]}.
    """
    U = check_wind_speed(U_m_s)
    f = _grid(f_hz, SPECTRA_F_HZ)
    k1 = 2.0 * np.pi * f / U
    spectra = one_point_spectra(k1, params)
    sigmas, lengths = [], []
    for name in ("F11", "F22", "F33"):
        target = 2.0 * spectra[name] * k1
        w = 1.0 / k1

        def best(ln_l, target=target, w=w):
            shape = kaimal_spectrum(f, 1.0, np.exp(ln_l), U) * f  # S f for sigma = 1
            var = max(np.sum(w * shape * target) / np.sum(w * shape * shape), 0.0)
            return np.sum(w * (var * shape - target) ** 2), var

        res = minimize_scalar(lambda x: best(x)[0], bounds=(np.log(0.1), np.log(1e5)), method="bounded",
                              options={"xatol": 1e-8})
        sigmas.append(float(np.sqrt(best(res.x)[1])))
        lengths.append(float(np.exp(res.x)))
    return {"sigma_m_s": tuple(sigmas), "length_scales_m": tuple(lengths), "f_hz": f}


def fit_yz_coherence(params: MannParams, U_m_s: float, f_hz=None, dy_m: float = 20.0, dz_m: float = 20.0):
    """(a_yz [-], Lc [m]) of the IEC coherence fitted to the Mann co-coherence of u (Guo et al. 2023, Eq. 21).

    Minimises sum_n (1/k1_n) (gamma_yz(f_n) - cocoh_11(k1_n, dy, dz))^2 at r = sqrt(dy^2 + dz^2) > 0.

    Parameters
    ----------
    params, U_m_s : MannParams, float
        Mann model and mean wind speed [m/s].
    f_hz : array_like, optional
        Fit frequencies [Hz]; default YZ_F_HZ (40 log-spaced, 1 mHz to 1 Hz).
    dy_m, dz_m : float, optional
        Lateral and vertical separation [m].
    """
    U = check_wind_speed(U_m_s)
    f = _grid(f_hz, YZ_F_HZ)
    k1 = 2.0 * np.pi * f / U
    r = float(np.hypot(check_finite("dy (m)", dy_m), check_finite("dz (m)", dz_m)))
    check_positive("separation sqrt(dy^2 + dz^2) (m)", r)
    _, cocoh = yz_coherence(k1, params, 0, 0, dy_m, dz_m)
    sw = 1.0 / np.sqrt(k1)

    def resid(x):
        return sw * (exponential_yz(r, f, U, np.exp(x[0]), np.exp(x[1])) - cocoh)

    sol = least_squares(resid, x0=[np.log(12.0), np.log(8.1 * 42.0)], method="lm", xtol=1e-12, ftol=1e-12)
    return float(np.exp(sol.x[0])), float(np.exp(sol.x[1]))


def fit_longitudinal(params: MannParams, U_m_s: float, dx_m: float = 100.0, f_hz=None):
    """(a_x [-], b_x [1/m]) of Eq. 18 fitted to the space-time longitudinal coherence (Guo et al. 2023, Eq. 22).

    Minimises sum_n (1/f_n) (gamma_x^2(dx, f_n) - coh2_11(f_n, dx))^2: the paper does not say which side is
    squared; the squared model against the magnitude-squared coherence (Eq. 16) reproduces its Table 2.

    Parameters
    ----------
    params, U_m_s : MannParams, float
        Mann model with ``evo_time_s`` set (frozen: ParameterError) and mean wind speed [m/s].
    dx_m, f_hz : float, array_like, optional
        Longitudinal separation [m], > 0; fit frequencies [Hz], default LONG_F_HZ (60 log-spaced, 3e-4 to 0.5 Hz).
    """
    if params.evo_time_s is None:
        raise ParameterError("evo (gamma, s) is needed to fit a longitudinal coherence (frozen turbulence has coh = 1)")
    U = check_wind_speed(U_m_s)
    dx = check_positive("dx (m)", dx_m)
    f = _grid(f_hz, LONG_F_HZ)
    coh2 = longitudinal_coherence(f, dx, U, params)
    sw = 1.0 / np.sqrt(f)
    b_scale = 1e-4  # b_x is O(1e-4) 1/m: optimise b_x / b_scale

    def resid(x):
        model = np.exp(-x[0] * dx * np.sqrt((f / U) ** 2 + (x[1] * b_scale) ** 2))
        return sw * (model - coh2)

    sol = least_squares(resid, x0=[2.0, 1.0], bounds=([0.0, 0.0], [np.inf, np.inf]), xtol=1e-12, ftol=1e-12)
    return float(sol.x[0]), float(sol.x[1] * b_scale)
