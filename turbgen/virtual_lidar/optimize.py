"""Brute-force search of a spinner lidar's range and half-cone angle (Fu et al. 2023 Sect. 3.5, Eq. 31).

Maximise k_0.5 subject to T_buffer = x/U - T_scan/2 - T_filter - T_pitch >= 0 (T_filter: Eq. 30)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from turbgen.errors import ParameterError, check_range
from turbgen.virtual_lidar.description import LidarDescription
from turbgen.theory.lidar_control import (PITCH_DELAY_RANGE_S, buffer_time_s, coherence_bandwidth_rad_m,
                                         cutoff_frequency_hz)
from turbgen.theory.lidar_preview import mann_preview_spectra
from turbgen.theory.params import MannParams

MAX_CANDIDATES = 2000


@dataclass(frozen=True)
class Candidate:
    """One evaluated lidar geometry: range x [m], half-cone phi [deg], k_0.5 [rad/m] (nan if gamma^2 never reaches
    0.5), -3 dB cut-off of |G_RL| [Hz] and T_buffer [s] (Fu et al. 2023 Eq. 31; nan without a cut-off)."""
    range_m: float
    half_cone_deg: float
    k05_rad_m: float
    cutoff_hz: float
    buffer_time_s: float


SEARCH_F_HZ = np.geomspace(2e-3, 0.25, 28)  # one spectral evaluation per candidate; crossings interpolated


def evaluate(lidar: LidarDescription, params: MannParams, U_m_s: float, *, pitch_delay_s: float = 0.9,
             f_delay_hz: float = 0.025, f_hz=SEARCH_F_HZ) -> Candidate:
    """The :class:`Candidate` of one lidar (first range gate x [m]) for the Mann model at U [m/s]; ParameterError for
    non-positive frequencies, a beam not looking upstream or a pitch delay out of range."""
    pitch_delay_s = check_range("pitch-delay (T_pitch, s)", pitch_delay_s, *PITCH_DELAY_RANGE_S)
    S = mann_preview_spectra(f_hz, lidar.measurement_points(), params, U_m_s, lidar.rotor_radius_m)
    k05 = coherence_bandwidth_rad_m(S.f_hz, S.coh2_RL, U_m_s)
    fc = cutoff_frequency_hz(S.f_hz, S.G_RL)
    x = lidar.ranges_m[0]
    tb = buffer_time_s(x, U_m_s, lidar.scan_time_s, fc, pitch_delay_s, f_delay_hz) if np.isfinite(fc) else np.nan
    return Candidate(x, lidar.half_cone_deg, k05, fc, tb)


def optimize_spinner(lidar: LidarDescription, params: MannParams, U_m_s: float, ranges_m, half_cones_deg,
                     *, pitch_delay_s: float = 0.9, progress=None) -> tuple[list[Candidate], Candidate | None]:
    """Every candidate of ``ranges_m`` x ``half_cones_deg`` (range-major) and the feasible one with the largest k_0.5;
    ParameterError if the lidar is not a spinner, the grid is empty or above MAX_CANDIDATES, or a value is invalid."""
    pitch_delay_s = check_range("pitch-delay (T_pitch, s)", pitch_delay_s, *PITCH_DELAY_RANGE_S)  # before any candidate
    if lidar.mount != "spinner":
        raise ParameterError(f"lidar {lidar.name!r}: the range x half-cone search is for spinner lidars")
    ranges = [float(x) for x in ranges_m]
    cones = [float(c) for c in half_cones_deg]
    if not ranges or not cones or len(ranges) * len(cones) > MAX_CANDIDATES:
        raise ParameterError(f"lidar optimize: {len(ranges)} ranges x {len(cones)} angles must be 1 to "
                             f"{MAX_CANDIDATES} candidates")
    out = []
    for x in ranges:
        for c in cones:
            out.append(evaluate(replace(lidar, ranges_m=(x,), half_cone_deg=c), params, U_m_s,
                                pitch_delay_s=pitch_delay_s))
            if progress is not None:
                progress(1)
    feasible = [c for c in out if np.isfinite(c.k05_rad_m) and c.buffer_time_s >= 0]
    return out, (max(feasible, key=lambda c: c.k05_rad_m) if feasible else None)
