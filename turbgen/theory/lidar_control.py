"""Lidar-assisted control design from the preview quality (turbgen.theory.lidar_preview): the -3 dB cut-off of
|G_RL|, the measurement coherence bandwidth k_0.5 where gamma^2 drops to 0.5 and d_eddy,min = 2 pi / k_0.5
(Fu et al. 2023 Eq. 26-27), the first-order low-pass filter and its delay (Fu et al. 2023 Eq. 30) and the
buffer time (Guo et al. 2023 Sect. 3.5).
"""

from __future__ import annotations

import numpy as np

from turbgen.errors import check_positive
from turbgen.theory.params import check_wind_speed

MINUS_3_DB = 10.0 ** (-3.0 / 20.0)


def _first_crossing(f: np.ndarray, y: np.ndarray, level: float) -> float:
    """The first frequency where the model curve y(f) falls below level; nan if never, f[0] if y[0] is below.

    Between the bracketing points f[j-1] (y >= level) and f[j] (y < level), the root of the cubic in log f through
    the four points around them (Lagrange; linear with fewer than four points), found by bisection inside the
    bracket, where the cubic changes sign. Error ~h^4 in the log-spacing h instead of the ~h^2 of linear
    interpolation: the Table 3 lidar's Mann neutral cut-off on 12, 14 and 60 log-spaced points came out 0.050641,
    0.050801 and 0.050779 Hz linearly (the 4th digit depended on the grid), 0.050813-0.050822 Hz this way, against
    0.050821 Hz on a fine grid around it.
    """
    below = np.flatnonzero(y < level)
    if below.size == 0:
        return float("nan")
    j = int(below[0])
    if j == 0:
        return float(f[0])
    x = np.log(f)
    if f.size < 4:
        t = (y[j - 1] - level) / (y[j - 1] - y[j])
        return float(np.exp(x[j - 1] + t * (x[j] - x[j - 1])))
    i0 = min(max(j - 2, 0), f.size - 4)
    xs, ys = x[i0:i0 + 4], y[i0:i0 + 4] - level

    def cubic(v: float) -> float:  # Lagrange form through (xs, ys)
        total = 0.0
        for a in range(4):
            term = ys[a]
            for b in range(4):
                if b != a:
                    term *= (v - xs[b]) / (xs[a] - xs[b])
            total += term
        return total

    lo, hi = x[j - 1], x[j]  # cubic(lo) = y[j-1] - level >= 0 > cubic(hi) = y[j] - level
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if cubic(mid) >= 0.0:
            lo = mid
        else:
            hi = mid
    return float(np.exp(0.5 * (lo + hi)))


def cutoff_frequency_hz(f_hz, gain) -> float:
    """The -3 dB cut-off: first frequency where ``|G_RL|`` drops below 10^(-3/20) (Guo et al. 2023 Table 5).

    Between the grid points: the root of the local cubic in log f (see _first_crossing; linear below 4 points).

    Parameters
    ----------
    f_hz : array_like
        Increasing frequencies [Hz], > 0.
    gain : array_like
        ``|G_RL|`` [-] at ``f_hz``.

    Returns
    -------
    float
        Cut-off frequency [Hz]; f_hz[0] if the gain starts below the level, nan if it never drops.
    """
    return _first_crossing(np.asarray(f_hz, float), np.asarray(gain, float), MINUS_3_DB)


def coherence_bandwidth_rad_m(f_hz, coh2, U_m_s: float) -> float:
    """MCB k_0.5 = 2 pi f_0.5 / U [rad/m], f_0.5 where gamma^2_RL drops below 0.5 (Fu et al. 2023 Eq. 26).

    Parameters
    ----------
    f_hz : array_like
        Increasing frequencies [Hz], > 0.
    coh2 : array_like
        Magnitude-squared coherence gamma^2_RL [-] at ``f_hz``.
    U_m_s : float
        Mean wind speed U [m/s].

    Returns
    -------
    float
        k_0.5 [rad/m]; nan if gamma^2 never drops below 0.5.
    """
    return 2.0 * np.pi * _first_crossing(np.asarray(f_hz, float), np.asarray(coh2, float), 0.5) / U_m_s


def smallest_eddy_m(k05_rad_m: float) -> float:
    """Smallest detectable eddy d_eddy,min = 2 pi / k_0.5 (Fu et al. 2023 Eq. 27).

    Parameters
    ----------
    k05_rad_m : float
        Measurement coherence bandwidth k_0.5 [rad/m].

    Returns
    -------
    float
        d_eddy,min [m].
    """
    return 2.0 * np.pi / k05_rad_m


def lowpass_gain(f_hz, cutoff_hz: float):
    """|G| of the first-order low-pass omega_c / (s + omega_c) (Fu et al. 2023 Eq. 28).

    Parameters
    ----------
    f_hz : array_like
        Frequency [Hz].
    cutoff_hz : float
        Cut-off frequency f_c = omega_c / (2 pi) [Hz].

    Returns
    -------
    numpy.ndarray
        1 / sqrt(1 + (f / f_c)^2) [-], shaped like ``f_hz``.

    Raises
    ------
    ParameterError
        If ``cutoff_hz`` is not a finite number > 0.
    """
    f = np.asarray(f_hz, dtype=float)
    return 1.0 / np.sqrt(1.0 + (f / check_positive("cut-off (Hz)", cutoff_hz)) ** 2)


def filter_delay_s(cutoff_hz: float, f_delay_hz: float = 0.025) -> float:
    """T_filter = arctan(f_delay / f_cutoff) / (2 pi f_delay), delay of the low-pass (Fu et al. 2023 Eq. 30).

    Parameters
    ----------
    cutoff_hz : float
        Cut-off frequency f_cutoff [Hz].
    f_delay_hz : float, optional
        Frequency f_delay at which the delay is evaluated [Hz] (default 0.025 Hz).

    Returns
    -------
    float
        T_filter [s].

    Raises
    ------
    ParameterError
        If ``cutoff_hz`` or ``f_delay_hz`` is not a finite number > 0.
    """
    fd = check_positive("f_delay (Hz)", f_delay_hz)
    return float(np.arctan(fd / check_positive("cut-off (Hz)", cutoff_hz)) / (2.0 * np.pi * fd))


def buffer_time_s(range_m: float, U_m_s: float, scan_time_s: float, cutoff_hz: float,
                  pitch_delay_s: float = 0.0, f_delay_hz: float = 0.025) -> float:
    """Buffer time T_buffer = x/U - T_scan/2 - T_filter - T_pitch (Fu et al. 2023 Sect. 3.5).

    Parameters
    ----------
    range_m : float
        Preview distance x upstream of the rotor [m].
    U_m_s : float
        Mean wind speed U [m/s].
    scan_time_s : float
        Duration of one full scan T_scan [s].
    cutoff_hz : float
        Cut-off frequency of the low-pass filter [Hz] (see filter_delay_s).
    pitch_delay_s : float, optional
        Pitch actuator delay T_pitch [s] (default 0).
    f_delay_hz : float, optional
        Frequency at which the filter delay is evaluated [Hz] (default 0.025 Hz).

    Returns
    -------
    float
        T_buffer [s].

    Raises
    ------
    ParameterError
        If ``U_m_s`` is outside the allowed range or ``cutoff_hz``, ``f_delay_hz`` is not > 0.
    """
    return (range_m / check_wind_speed(U_m_s) - 0.5 * scan_time_s - filter_delay_s(cutoff_hz, f_delay_hz)
            - pitch_delay_s)
