"""Line-of-sight spectra of a lidar in a Kaimal field and the lidar turbulence-intensity correction.

Guo et al. 2023, Sect. 3; Schlipf et al. 2020; the geometry of turbgen.theory.lidar_geometry."""

from __future__ import annotations

import numpy as np

from turbgen.errors import ParameterError, check_positive
from turbgen.theory.coherence_models import exponential_yz
from turbgen.theory.kaimal import kaimal_spectrum
from turbgen.theory.lidar_geometry import Measurements
from turbgen.theory.params import KaimalParams, check_wind_speed


def kaimal_los_spectra(f_hz, meas: Measurements, kparams: KaimalParams, U_m_s: float, *,
                       vw_coherence: bool = False) -> np.ndarray:
    """One-sided spectra S_los,i(f) [m^2 s^-2 Hz^-1], (M, n_f), of each measurement's line-of-sight speed in the IEC
    Kaimal model ``kparams`` at U [m/s] through the probe volume (Schlipf et al. 2020, Eq. 2, 6; Taylor within it): u is
    coherent in the yz plane, v and w are spatially white unless ``vw_coherence``."""
    f = np.atleast_1d(np.asarray(f_hz, dtype=float))
    U = check_wind_speed(U_m_s)
    pts = meas.sample_points_m()
    out = np.empty((meas.count, f.size))
    for i in range(meas.count):
        w = meas.weights[i]
        delay = (pts[i, :, 0] - meas.focus_m[i, 0]) / U
        r = np.hypot(pts[i, :, 1, None] - pts[i, None, :, 1], pts[i, :, 2, None] - pts[i, None, :, 2])
        for m, fm in enumerate(f):
            a = w * np.exp(2j * np.pi * fm * delay)
            total = 0.0
            for c in range(3):
                S_c = kaimal_spectrum(fm, kparams.sigma_m_s[c], kparams.length_scales_m[c], U)
                coh = exponential_yz(r, fm, U, kparams.a_yz, kparams.lc_m) if (c == 0 or vw_coherence) \
                    else (r < 1e-9).astype(float)
                total += meas.n[i, c] ** 2 * S_c * np.real(a @ coh @ a.conj())
            out[i, m] = total
    return out


def lidar_ti_correction(meas: Measurements, kparams: KaimalParams, U_m_s: float, *, averaging_s: float = 600.0,
                        f_scan_hz: float = 1.0, f_max_hz: float = 1.0, n_f: int = 120) -> np.ndarray:
    """TI correction factor c_TI = sigma_u / sigma_L [-] per measurement, (M,) (Schlipf et al. 2020, Eq. 6-8).

    sigma_L^2 = ∫_{1/T}^{f_scan} S_los df (each point seen f_scan times a second, through its probe volume
    and beam angle), sigma_u^2 = ∫_{1/T}^{f_max} S_u df; the lidar TI multiplies each LOS standard
    deviation by its c_TI. ``averaging_s`` T [s], ``f_scan_hz`` > 1/T and ``f_max_hz`` [Hz]; ``n_f``
    log-spaced frequencies of the sigma_L^2 quadrature; the rest as :func:`kaimal_los_spectra`."""
    from turbgen.theory.kaimal import kaimal_band_variance

    T = check_positive("averaging time T (s)", averaging_s)
    f_scan = check_positive("f_scan (Hz)", f_scan_hz)
    if f_scan <= 1.0 / T:
        raise ParameterError(f"f_scan = {f_scan:g} Hz must exceed 1/T = {1.0 / T:g} Hz")
    f = np.geomspace(1.0 / T, f_scan, n_f)
    S = kaimal_los_spectra(f, meas, kparams, U_m_s)
    var_l = np.trapezoid(S * f, np.log(f), axis=-1)  # ∫ S df = ∫ S f dln f
    var_u = kaimal_band_variance(1.0 / T, check_positive("f_max (Hz)", f_max_hz), kparams.sigma_m_s[0],
                                 kparams.length_scales_m[0], U_m_s)
    return np.sqrt(var_u / var_l)
