"""Lidar-assisted control design from the preview quality (turbgen.theory.lidar_preview).

The -3 dB cut-off of |G_RL|, the measurement coherence bandwidth k_0.5 (Fu et al. 2023, Eq. 26; the
smallest detectable eddy is 2 pi / k_0.5, Eq. 27), the delay of the first-order low-pass (Fu et al.
2023, Eq. 30) and the buffer time (Guo et al. 2023, Sect. 3.5). Frequencies are increasing and > 0 [Hz]."""

from __future__ import annotations

import numpy as np

from turbgen.errors import check_positive
from turbgen.theory.params import check_wind_speed

MINUS_3_DB = 10.0 ** (-3.0 / 20.0)
PITCH_DELAY_RANGE_S = (0.0, 10.0)  # allowed T_pitch [s]: a pitch actuator's delay (0.9 s for the IEA 15 MW)


def _first_crossing(f: np.ndarray, y: np.ndarray, level: float) -> float:
    """The first f where y(f) falls below ``level`` (nan if never, f[0] if y[0] is below): the root of the Lagrange
    cubic in log f through the four points around it (error ~h^4 in the log-spacing h, linear's ~h^2)."""
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
    """The -3 dB cut-off [Hz]: first f where ``gain`` = ``|G_RL|`` drops below 10^(-3/20) (Guo et al. 2023, Table 5).

    ``f_hz`` increasing [Hz], ``gain`` [-] at them; f_hz[0] if the gain starts below the level, nan if it never drops.
    """
    return _first_crossing(np.asarray(f_hz, float), np.asarray(gain, float), MINUS_3_DB)


def coherence_bandwidth_rad_m(f_hz, coh2, U_m_s: float) -> float:
    """MCB k_0.5 = 2 pi f_0.5 / U [rad/m], f_0.5 where gamma^2_RL drops below 0.5 (Fu et al. 2023, Eq. 26).

    ``f_hz`` increasing [Hz], ``coh2`` gamma^2_RL [-] at them, ``U_m_s`` [m/s]; nan if gamma^2 never drops below 0.5."""
    return 2.0 * np.pi * _first_crossing(np.asarray(f_hz, float), np.asarray(coh2, float), 0.5) / U_m_s


def filter_delay_s(cutoff_hz: float, f_delay_hz: float = 0.025) -> float:
    """Low-pass delay T_filter = arctan(f_delay / f_cutoff) / (2 pi f_delay) [s] (Fu et al. 2023, Eq. 30)."""
    fd = check_positive("f_delay (Hz)", f_delay_hz)
    return float(np.arctan(fd / check_positive("cut-off (Hz)", cutoff_hz)) / (2.0 * np.pi * fd))


def buffer_time_s(range_m: float, U_m_s: float, scan_time_s: float, cutoff_hz: float,
                  pitch_delay_s: float = 0.0, f_delay_hz: float = 0.025) -> float:
    """Buffer time T_buffer = x/U - T_scan/2 - T_filter - T_pitch [s] (Fu et al. 2023, Sect. 3.5) of the preview
    distance x [m] and U [m/s]; scan and pitch-actuator times [s]; ``cutoff_hz``, ``f_delay_hz`` as
    :func:`filter_delay_s`."""
    return (range_m / check_wind_speed(U_m_s) - 0.5 * scan_time_s - filter_delay_s(cutoff_hz, f_delay_hz)
            - pitch_delay_s)
