"""One virtual-lidar run on a store, shared by ``turbgen lidar`` and ``turbgen sweep --lidar``."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError
from turbgen.virtual_lidar import sampling
from turbgen.virtual_lidar.sampling import Measurement


def measurements_of(description) -> list[Measurement]:
    """The description's beam-gates as :class:`Measurement` rows, each on the plane of its gate's range
    ``ranges_m[gate]`` when the description has ``ranges_m``."""
    m = description.measurement_points()
    ranges = getattr(description, "ranges_m", None)
    return [
        Measurement(int(m.beam[i]), int(m.gate[i]), tuple(m.n[i]), tuple(m.focus_m[i]), tuple(m.offsets_m[i]),
                    tuple(m.weights[i]), tuple(m.direction[i]),
                    None if ranges is None else float(ranges[int(m.gate[i])]))
        for i in range(m.count)
    ]


def lidar_attrs(description) -> dict:
    """Every parameter of the description: its ``to_attrs()``, else its dataclass fields, else its repr."""
    if hasattr(description, "to_attrs"):
        return dict(description.to_attrs())
    if dataclasses.is_dataclass(description):
        return {f.name: getattr(description, f.name) for f in dataclasses.fields(description)}
    return {"description": repr(description)}


@dataclass
class LidarRun:
    """The result of one virtual-lidar run (:func:`run_lidar`): u_LL, u_RR [m/s], TIs [-], Welch output."""
    samples: sampling.LidarSamples
    t_arrival_s: np.ndarray
    u_LL: np.ndarray
    u_RR: np.ndarray
    ti_lidar: float
    ti_rotor: float
    welch: dict
    simulated: dict
    rotor_radius_m: float


def default_nperseg(n: int) -> int:
    """Welch segment length [samples]: the largest power of two <= n / 8 (about 15 half-overlapping segments),
    at least 16; ParameterError if ``n`` < 64."""
    if n < 64:
        raise ParameterError(f"lidar signal of {n} samples is too short (needs >= 64 scan steps)")
    return max(16, 2 ** int(np.floor(np.log2(n / 8))))


def check_lidar_fits(description, grid) -> None:
    """Refuse a lidar whose gates are not planes of ``grid`` or whose probe volumes leave it, before any field
    exists (ParameterError, as ``sampling.check_measurements``)."""
    from types import SimpleNamespace

    sampling.check_measurements(SimpleNamespace(grid=grid), measurements_of(description))


def run_lidar(fs, description, *, rotor_radius_m=None, add_mean_wind=False, shear_exponent=0.2,
              nperseg=None, mean_wind=None) -> LidarRun:
    """Sample ``fs`` with ``description`` and estimate the simulated preview quality; ``description``: any object with
    ``measurement_points()`` and ``schedule(duration_s)``; ``rotor_radius_m`` [m] (None: the validator's default); mean
    wind as in :func:`turbgen.virtual_lidar.sampling.sample`. ParameterError for a radius that does not fit the grid, a
    lidar that does not fit the store, no plane x = 0, or a short signal."""
    # the estimators here only: placing lidar data (constrained runs) needs this module but not scipy.signal
    from turbgen.virtual_lidar import compare, signals
    from turbgen.validation.estimators import WelchSetup
    from turbgen.validation.point_sets import check_rotor_radius

    g = fs.grid
    radius = check_rotor_radius(g, rotor_radius_m)
    ms = measurements_of(description)
    times, beams = description.schedule(g.nt * g.dt_s)
    s = sampling.sample(fs, ms, times, beams, add_mean_wind=add_mean_wind, shear_exponent=shear_exponent,
                        mean_wind=mean_wind)
    t_arr, u_ll = signals.lidar_estimate(s, fs.U_m_s)
    u_rr, ti_r = signals.rotor_average(fs, radius, t_arr)
    setup = WelchSetup(nperseg or default_nperseg(u_ll.size), float(t_arr[1] - t_arr[0]))
    w = signals.welch_rl(u_ll, u_rr, setup)  # segment means removed: the mean wind does not enter
    sim = compare.preview_numbers(w["f_hz"], w["coh2_RL"], w["G_RL"], fs.U_m_s)
    return LidarRun(s, t_arr, u_ll, u_rr, signals.lidar_ti(s, fs.U_m_s), ti_r, w, sim, radius)
