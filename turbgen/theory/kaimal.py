"""IEC 61400-1 Kaimal spectra and normal-turbulence-model parameters (Guo et al. 2023, Sect. 2.2)."""

from __future__ import annotations

import numpy as np

from turbgen.errors import check_choice, check_positive
from turbgen.theory.params import KaimalParams, check_wind_speed

# IEC 61400-1 reference turbulence intensity per class (NTM)
IEC_IREF = {"A+": 0.18, "A": 0.16, "B": 0.14, "C": 0.12}
# L_k = {8.1, 2.7, 0.66} Lambda1 (IEC 61400-1 Annex C); sigma2 = 0.8 sigma1, sigma3 = 0.5 sigma1
IEC_LENGTH_FACTORS = (8.1, 2.7, 0.66)
IEC_SIGMA_RATIOS = (1.0, 0.8, 0.5)


def kaimal_spectrum(f_hz, sigma_m_s: float, length_scale_m: float, U_m_s: float):
    """One-sided Kaimal PSD S(f) = 4 sigma^2 (L/U) / (1 + 6 f L/U)^(5/3) (Guo et al. 2023, Eq. 11).

    Parameters
    ----------
    f_hz : array_like
        Frequency [Hz] (only ``|f|`` is used); S(f) [m^2 s^-2 Hz^-1] has its shape, ∫_0^inf S df = sigma^2.
    sigma_m_s, length_scale_m, U_m_s : float
        Standard deviation of the component [m/s], Kaimal integral length scale L [m], mean wind speed [m/s].
    """
    f = np.asarray(f_hz, dtype=float)
    n = length_scale_m / U_m_s
    return 4.0 * sigma_m_s**2 * n / (1.0 + 6.0 * np.abs(f) * n) ** (5.0 / 3.0)


def kaimal_band_variance(f_lo_hz, f_hi_hz, sigma_m_s: float, length_scale_m: float, U_m_s: float):
    """Variance ∫ S(f) df [m^2 s^-2] of :func:`kaimal_spectrum` between ``f_lo_hz`` and ``f_hi_hz`` [Hz], closed form.

    The antiderivative of Eq. 11 (Guo et al. 2023) is -sigma^2 (1 + 6 f L/U)^(-2/3); the edges broadcast."""
    n = length_scale_m / U_m_s
    lo = np.asarray(f_lo_hz, dtype=float)
    hi = np.asarray(f_hi_hz, dtype=float)
    return sigma_m_s**2 * ((1.0 + 6.0 * lo * n) ** (-2.0 / 3.0) - (1.0 + 6.0 * hi * n) ** (-2.0 / 3.0))


def iec_lambda1_m(hub_height_m: float) -> float:
    """IEC 61400-1 longitudinal scale parameter Lambda1 [m]: 0.7 z_hub below 60 m, else 42 m."""
    z = check_positive("hub height (m)", hub_height_m)
    return 0.7 * z if z < 60.0 else 42.0


def iec_sigma1_m_s(U_m_s: float, turb_class: str = "A") -> float:
    """NTM standard deviation sigma1 = Iref (0.75 U + 5.6) [m/s] (IEC 61400-1) at hub speed U [m/s]; ``turb_class``
    "A+", "A", "B" or "C" sets Iref = 0.18, 0.16, 0.14, 0.12; ParameterError for another class or a speed outside
    turbgen.theory.ranges."""
    check_choice("class", turb_class, tuple(IEC_IREF))
    return IEC_IREF[turb_class] * (0.75 * check_wind_speed(U_m_s) + 5.6)


def iec_kaimal_params(U_m_s: float, turb_class: str = "A", hub_height_m: float = 90.0) -> KaimalParams:
    """IEC 61400-1 Kaimal model at hub-height speed U.

    sigma_k = (1, 0.8, 0.5) sigma1, L_k = (8.1, 2.7, 0.66) Lambda1, a_yz = 12, Lc = 8.1 Lambda1.

    Parameters
    ----------
    U_m_s, turb_class, hub_height_m : float, str, float
        Hub-height mean wind speed [m/s], turbulence class ("A+", "A", "B", "C"), hub height [m] (sets Lambda1).

    Returns
    -------
    KaimalParams
    """
    lam = iec_lambda1_m(hub_height_m)
    s1 = iec_sigma1_m_s(U_m_s, turb_class)
    return KaimalParams(sigma_m_s=tuple(r * s1 for r in IEC_SIGMA_RATIOS),
                        length_scales_m=tuple(c * lam for c in IEC_LENGTH_FACTORS), a_yz=12.0, lc_m=8.1 * lam)
