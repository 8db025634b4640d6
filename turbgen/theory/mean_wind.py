"""Mean-wind profiles and directional veer: pure functions of height, SI units.

The profiles are the shapes TurbSim offers (Jonkman 2009, TurbSim User's Guide, "WindProfileType"):
the power law (IEC 61400-1 Ed. 4, 2019, Sect. 6.3.2.2, the normal wind profile) and the logarithmic law
of a neutral surface layer with a displacement height (Jonkman 2009, "LOG" profile); each is returned as the ratio
U(h) / U(h_ref), so the speed at the reference (hub) height is set elsewhere. Veer turns the horizontal
velocity by an angle theta(h) counter-clockwise seen from above (towards +y, which points left looking
downwind), the rotation TurbSim applies per height (Jonkman 2009, "WindDir" of the user profile):
u' = u cos(theta) - v sin(theta), v' = u sin(theta) + v cos(theta).
"""

from __future__ import annotations

import numpy as np


def power_law_ratio(heights_m, ref_height_m: float, exponent: float) -> np.ndarray:
    """Power-law profile ratio U(h) / U(h_ref) = (h / h_ref)^alpha (IEC 61400-1 Ed. 4, Sect. 6.3.2.2).

    Parameters
    ----------
    heights_m : array_like
        Heights above ground [m], > 0.
    ref_height_m : float
        Reference (hub) height [m], > 0.
    exponent : float
        Shear exponent alpha [-].

    Returns
    -------
    numpy.ndarray
        U(h) / U(h_ref) [-], shape of ``heights_m``.
    """
    return (np.asarray(heights_m, dtype=float) / ref_height_m) ** exponent


def log_law_ratio(heights_m, ref_height_m: float, roughness_m: float, displacement_m: float = 0.0) -> np.ndarray:
    """Logarithmic profile ratio U(h) / U(h_ref) = ln((h - d) / z0) / ln((h_ref - d) / z0) (Jonkman 2009, neutral "LOG" profile).

    Parameters
    ----------
    heights_m : array_like
        Heights above ground [m], each > d + z0 (the profile is zero at h = d + z0).
    ref_height_m : float
        Reference (hub) height [m], > d + z0.
    roughness_m : float
        Roughness length z0 [m], > 0.
    displacement_m : float, optional
        Displacement height d [m] (default 0).

    Returns
    -------
    numpy.ndarray
        U(h) / U(h_ref) [-], shape of ``heights_m``.
    """
    h = np.asarray(heights_m, dtype=float)
    return np.log((h - displacement_m) / roughness_m) / np.log((ref_height_m - displacement_m) / roughness_m)


def table_ratio(heights_m, table_heights_m, table_speeds_m_s, ref_height_m: float) -> np.ndarray:
    """Tabulated profile ratio U(h) / U(h_ref), U linear between the table's heights.

    Parameters
    ----------
    heights_m : array_like
        Heights [m], inside [table_heights_m[0], table_heights_m[-1]].
    table_heights_m : array_like
        Strictly increasing heights of the table [m].
    table_speeds_m_s : array_like
        Speeds at those heights [m/s]; the value at ``ref_height_m`` must be > 0.
    ref_height_m : float
        Reference (hub) height [m], inside the table.

    Returns
    -------
    numpy.ndarray
        U(h) / U(h_ref) [-], shape of ``heights_m``.
    """
    ref = np.interp(ref_height_m, table_heights_m, table_speeds_m_s)
    return np.interp(np.asarray(heights_m, dtype=float), table_heights_m, table_speeds_m_s) / ref


def linear_veer_deg(heights_m, ref_height_m: float, rate_deg_per_m: float) -> np.ndarray:
    """Veer angle theta(h) = rate (h - h_ref) [deg], counter-clockwise seen from above.

    Parameters
    ----------
    heights_m : array_like
        Heights [m].
    ref_height_m : float
        Reference (hub) height [m], where theta = 0.
    rate_deg_per_m : float
        Direction change with height [deg/m] (northern-hemisphere veer, clockwise with height, is negative).

    Returns
    -------
    numpy.ndarray
        theta [deg], shape of ``heights_m``.
    """
    return rate_deg_per_m * (np.asarray(heights_m, dtype=float) - ref_height_m)


def rotate_horizontal(u, v, angle_deg):
    """(u, v) turned by ``angle_deg`` counter-clockwise seen from above (TurbSim's per-height rotation).

    Parameters
    ----------
    u, v : array_like
        Velocity components along x (downwind) and y (left) [m/s], broadcastable with ``angle_deg``.
    angle_deg : array_like
        Rotation angle [deg].

    Returns
    -------
    tuple of numpy.ndarray
        (u cos(theta) - v sin(theta), u sin(theta) + v cos(theta)) [m/s].
    """
    a = np.deg2rad(angle_deg)
    c, s = np.cos(a), np.sin(a)
    return u * c - v * s, u * s + v * c
