"""Mean-wind profiles and directional veer: pure functions of height [m], SI units.

The profiles TurbSim offers (Jonkman 2009, TurbSim User's Guide, "WindProfileType"), each as the ratio
U(h) / U(h_ref) so the hub speed is set elsewhere. Veer turns the horizontal velocity by theta(h)
counter-clockwise seen from above (towards +y, left looking downwind), as TurbSim per height."""

from __future__ import annotations

import numpy as np


def power_law_ratio(heights_m, ref_height_m: float, exponent: float) -> np.ndarray:
    """Power-law ratio (h / h_ref)^alpha [-] at ``heights_m`` > 0 (IEC 61400-1 Ed. 4, Sect. 6.3.2.2)."""
    return (np.asarray(heights_m, dtype=float) / ref_height_m) ** exponent


def log_law_ratio(heights_m, ref_height_m: float, roughness_m: float, displacement_m: float = 0.0) -> np.ndarray:
    """Neutral log-law ratio ln((h - d) / z0) / ln((h_ref - d) / z0) [-] (Jonkman 2009, "LOG" profile); heights and
    h_ref must exceed d + z0 (roughness length z0 > 0 and displacement d, all in m)."""
    h = np.asarray(heights_m, dtype=float)
    return np.log((h - displacement_m) / roughness_m) / np.log((ref_height_m - displacement_m) / roughness_m)


def table_ratio(heights_m, table_heights_m, table_speeds_m_s, ref_height_m: float) -> np.ndarray:
    """Tabulated ratio U(h) / U(h_ref) [-], U linear between the strictly increasing ``table_heights_m`` [m]; heights
    and ``ref_height_m`` lie inside the table; the speed [m/s] at the reference must be > 0."""
    ref = np.interp(ref_height_m, table_heights_m, table_speeds_m_s)
    return np.interp(np.asarray(heights_m, dtype=float), table_heights_m, table_speeds_m_s) / ref


def linear_veer_deg(heights_m, ref_height_m: float, rate_deg_per_m: float) -> np.ndarray:
    """Veer angle theta(h) = rate (h - h_ref) [deg] counter-clockwise seen from above; ``rate_deg_per_m`` [deg/m] is
    negative for northern-hemisphere veer (clockwise with height)."""
    return rate_deg_per_m * (np.asarray(heights_m, dtype=float) - ref_height_m)


def rotate_horizontal(u, v, angle_deg):
    """(u cos(theta) - v sin(theta), u sin(theta) + v cos(theta)) [m/s]: (u, v) turned by ``angle_deg``, u along x
    (downwind), v along y (left); broadcast against the angle [deg]."""
    a = np.deg2rad(angle_deg)
    c, s = np.cos(a), np.sin(a)
    return u * c - v * s, u * s + v * c
