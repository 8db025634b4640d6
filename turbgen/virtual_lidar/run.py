"""One virtual-lidar run on a store: sample -> u_LL, u_RR, TI -> Welch gamma^2_RL, |G_RL| -> dataset.

Shared by ``turbgen lidar`` and ``turbgen sweep --lidar``. The lidar is described by an object
with ``measurement_points()`` (per beam-gate: beam, gate, n, focus, probe offsets, weights) and
``schedule(duration_s)`` -> (times_s, beam index), see ``turbgen.virtual_lidar.description``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError
from turbgen.virtual_lidar import sampling
from turbgen.virtual_lidar.sampling import Measurement


def measurements_of(description) -> list[Measurement]:
    """The description's beam-gates as :class:`Measurement` rows.

    Rows of ``turbgen.theory.lidar_geometry.Measurements``, each taken from the plane of its gate's
    range ``ranges_m[gate]`` (if the description has ``ranges_m``).

    Parameters
    ----------
    description : LidarDescription or object
        Anything with ``measurement_points()`` (and optionally ``ranges_m`` [m]).

    Returns
    -------
    list of Measurement
        One per beam-gate.
    """
    m = description.measurement_points()
    ranges = getattr(description, "ranges_m", None)
    return [
        Measurement(int(m.beam[i]), int(m.gate[i]), tuple(m.n[i]), tuple(m.focus_m[i]), tuple(m.offsets_m[i]),
                    tuple(m.weights[i]), tuple(m.direction[i]),
                    None if ranges is None else float(ranges[int(m.gate[i])]))
        for i in range(m.count)
    ]


def lidar_attrs(description) -> dict:
    """Every parameter of the description (its ``to_attrs``, else its dataclass fields, else its repr).

    Parameters
    ----------
    description : LidarDescription or object
        The lidar description.

    Returns
    -------
    dict
        Parameter name -> value.
    """
    if hasattr(description, "to_attrs"):
        return dict(description.to_attrs())
    if dataclasses.is_dataclass(description):
        return {f.name: getattr(description, f.name) for f in dataclasses.fields(description)}
    return {"description": repr(description)}


@dataclass
class LidarRun:
    """The result of one virtual-lidar run (see :func:`run_lidar`).

    Parameters
    ----------
    samples : LidarSamples
        Sampled line-of-sight speeds.
    t_arrival_s : numpy.ndarray
        Rotor arrival time axis [s].
    u_LL : numpy.ndarray
        Lidar estimate of the rotor-effective wind speed [m/s].
    u_RR : numpy.ndarray
        Rotor-disc average u at x = 0 [m/s].
    ti_lidar : float
        Uncorrected lidar turbulence intensity [-].
    ti_rotor : float
        Rotor-averaged turbulence intensity [-].
    welch : dict
        Output of :func:`turbgen.virtual_lidar.signals.welch_rl`.
    simulated : dict
        k05_rad_m [rad/m], d_eddy_min_m [m], cutoff_hz [Hz] of the simulated curves.
    rotor_radius_m : float
        Rotor radius R used [m].
    """
    samples: sampling.LidarSamples
    t_arrival_s: np.ndarray
    u_LL: np.ndarray
    u_RR: np.ndarray
    ti_lidar: float
    ti_rotor: float
    welch: dict
    simulated: dict  # k05_rad_m, d_eddy_min_m, cutoff_hz of the simulated curves
    rotor_radius_m: float


def default_nperseg(n: int) -> int:
    """Largest power of two <= n / 8 (about 15 half-overlapping Welch segments), at least 16.

    Parameters
    ----------
    n : int
        Signal length [samples] (scan steps).

    Returns
    -------
    int
        Welch segment length [samples].

    Raises
    ------
    ParameterError
        If ``n`` < 64.
    """
    if n < 64:
        raise ParameterError(f"lidar signal of {n} samples is too short (needs >= 64 scan steps)")
    return max(16, 2 ** int(np.floor(np.log2(n / 8))))


def check_lidar_fits(description, grid) -> None:
    """Refuse a lidar whose gates are not planes of ``grid`` or whose probe volumes leave it (before any field exists).

    Parameters
    ----------
    description : LidarDescription or object
        The lidar (``measurement_points()``).
    grid : Grid
        The grid of the stores it will measure.

    Returns
    -------
    None

    Raises
    ------
    ParameterError
        As :func:`turbgen.virtual_lidar.sampling.check_measurements` (it reads only the store's grid).
    """
    from types import SimpleNamespace

    sampling.check_measurements(SimpleNamespace(grid=grid), measurements_of(description))


def run_lidar(fs, description, *, rotor_radius_m=None, add_mean_wind=False, shear_exponent=0.2,
              nperseg=None, mean_wind=None) -> LidarRun:
    """Sample ``fs`` with ``description`` and estimate the simulated preview quality.

    Parameters
    ----------
    fs : FieldStore
        The open store.
    description : LidarDescription or object
        The lidar (``measurement_points()`` and ``schedule(duration_s)``).
    rotor_radius_m : float, optional
        Rotor radius R [m] (0 < R <= half the smaller grid extent); None: the validator's default.
    add_mean_wind : bool, optional
        Add the power-law mean wind to u before sampling (default False).
    shear_exponent : float, optional
        Power-law exponent alpha [-] of the mean wind (default 0.2).
    nperseg : int, optional
        Welch segment length [samples]; None: :func:`default_nperseg`.
    mean_wind : MeanWind, optional
        With ``add_mean_wind``: this mean wind instead of the power law (see :func:`turbgen.virtual_lidar.sampling.sample`).

    Returns
    -------
    LidarRun
        Samples, u_LL, u_RR, TIs, Welch spectra and the simulated k_0.5 and cut-off.

    Raises
    ------
    ParameterError
        For a rotor radius that does not fit the grid, a lidar that does not fit the store (see
        :func:`turbgen.virtual_lidar.sampling.sample`), a store without a plane x = 0, or a signal too short.
    """
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
    step = float(t_arr[1] - t_arr[0])
    setup = WelchSetup(nperseg or default_nperseg(u_ll.size), step)
    w = signals.welch_rl(u_ll, u_rr, setup)  # segment means removed: the mean wind does not enter
    sim = compare.preview_numbers(w["f_hz"], w["coh2_RL"], w["G_RL"], fs.U_m_s)
    return LidarRun(s, t_arr, u_ll, u_rr, signals.lidar_ti(s, fs.U_m_s), ti_r, w, sim, radius)
