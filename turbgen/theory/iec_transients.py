"""IEC 61400-1 Ed. 4 (2019) extreme deterministic wind events, Sect. 6.3.3: pure functions, SI units.

Time t [s] runs from the start of the event: the formulas hold for 0 <= t <= T, the undisturbed value
before and the final one after. Angles in degrees. sigma1 is the normal-turbulence-model standard
deviation and Lambda1 the longitudinal scale parameter (:mod:`turbgen.theory.kaimal`); D the rotor
diameter [m]. EOG: Sect. 6.3.3.3, EDC: 6.3.3.5, ECD: 6.3.3.6, EWS: 6.3.3.7."""

from __future__ import annotations

import numpy as np

V_REF_M_S = {"I": 50.0, "II": 42.5, "III": 37.5}  # reference wind speed per turbine class (Sect. 6.2)
EOG_PERIOD_S, EDC_PERIOD_S, ECD_PERIOD_S, EWS_PERIOD_S = 10.5, 6.0, 10.0, 12.0
ECD_GUST_M_S = 15.0
EWS_BETA = 6.4


def extreme_speeds_m_s(v_ref_m_s: float) -> tuple[float, float]:
    """(V_e50, V_e1) = (1.4 V_ref, 0.8 V_e50) [m/s], the 50- and 1-year 3-s gusts at hub height (Sect. 6.3.3.2)."""
    ve50 = 1.4 * v_ref_m_s
    return ve50, 0.8 * ve50


def _window(t, period_s):
    """t [s] clipped to [0, T] (the event's clock, frozen before and after it)."""
    return np.clip(np.asarray(t, dtype=float), 0.0, period_s)


def eog_gust_m_s(v_hub_m_s: float, v_e1_m_s: float, sigma1_m_s: float, diameter_m: float, lambda1_m: float) -> float:
    """EOG magnitude V_gust = min(1.35 (V_e1 - V_hub), 3.3 sigma1 / (1 + 0.1 D / Lambda1)) [m/s]."""
    return min(1.35 * (v_e1_m_s - v_hub_m_s), 3.3 * sigma1_m_s / (1.0 + 0.1 * diameter_m / lambda1_m))


def eog_speed_change_m_s(t_s, gust_m_s: float, period_s: float = EOG_PERIOD_S) -> np.ndarray:
    """EOG speed change -0.37 V_gust sin(3 pi t / T) (1 - cos(2 pi t / T)) [m/s] at ``t_s`` [s], 0 outside [0, T]."""
    t = _window(t_s, period_s)
    return -0.37 * gust_m_s * np.sin(3.0 * np.pi * t / period_s) * (1.0 - np.cos(2.0 * np.pi * t / period_s))


def edc_angle_deg(v_hub_m_s: float, sigma1_m_s: float, diameter_m: float, lambda1_m: float) -> float:
    """EDC magnitude theta_e = 4 arctan(sigma1 / (V_hub (1 + 0.1 D / Lambda1))) [deg], at most 180 deg."""
    theta = 4.0 * np.degrees(np.arctan(sigma1_m_s / (v_hub_m_s * (1.0 + 0.1 * diameter_m / lambda1_m))))
    return float(min(theta, 180.0))


def cosine_rise(t_s, amplitude: float, period_s: float) -> np.ndarray:
    """0.5 A (1 - cos(pi t / T)) at ``t_s`` [s], in A's unit: 0 before the event, A after (EDC, ECD)."""
    return 0.5 * amplitude * (1.0 - np.cos(np.pi * _window(t_s, period_s) / period_s))


def ecd_angle_deg(v_hub_m_s: float) -> float:
    """ECD direction change theta_cg [deg]: 180 below 4 m/s, else 720 deg m/s / V_hub."""
    return 180.0 if v_hub_m_s < 4.0 else 720.0 / v_hub_m_s


def ews_amplitude_m_s(sigma1_m_s: float, diameter_m: float, lambda1_m: float) -> float:
    """EWS speed change across one diameter, 2.5 m/s + 0.2 beta sigma1 (D / Lambda1)^(1/4) [m/s], beta = 6.4."""
    return 2.5 + 0.2 * EWS_BETA * sigma1_m_s * (diameter_m / lambda1_m) ** 0.25


def ews_factor(t_s, period_s: float = EWS_PERIOD_S) -> np.ndarray:
    """EWS time factor 1 - cos(2 pi t / T) [-] at ``t_s`` [s], 0 outside [0, T]."""
    return 1.0 - np.cos(2.0 * np.pi * _window(t_s, period_s) / period_s)


def etm_sigma1_m_s(v_hub_m_s: float, i_ref: float, v_ref_m_s: float) -> float:
    """Extreme turbulence model sigma1 [m/s] (Sect. 6.3.3.4).

    sigma1 = c I_ref (0.072 (V_ave / c + 3) (V_hub / c - 4) + 10), c = 2 m/s, V_ave = 0.2 V_ref, from the
    hub speed and the class's reference speed [m/s] and reference intensity I_ref [-]."""
    c = 2.0
    return c * i_ref * (0.072 * (0.2 * v_ref_m_s / c + 3.0) * (v_hub_m_s / c - 4.0) + 10.0)
