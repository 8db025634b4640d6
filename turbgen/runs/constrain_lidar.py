"""Lidar line-of-sight data as constraints: a ``turbgen lidar --out`` dataset placed on a run's grid.

The operator is the virtual lidar's own (virtual_lidar.sampling.los_operator), rebuilt from the dataset's lidar
description and times. Each beam-gate is one stream observed once per scan, so the scan period must be a whole number
q of time steps (Streams with decimation q). A mean wind the dataset added is subtracted along the line of sight
(its recorded MeanWind, else the power law); a turning mean wind is refused (it turned the measured line of sight)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from turbgen.errors import ParameterError
from turbgen.virtual_lidar.dataset import LidarData
from turbgen.virtual_lidar.description import lidar_from_mapping
from turbgen.virtual_lidar.run import measurements_of
from turbgen.virtual_lidar.sampling import (check_measurements, los_operator, mean_wind_los, mean_wind_los_series,
                                    repeats_every)  # fmt: skip
from turbgen.spec.mean_wind import MeanWind

_WEIGHT_TOL = 1e-9  # weights of one term that differ by less between scans are the same (rounding of T + x'/U)


def _scan_step(data: LidarData, dt_s: float, where: str) -> int:
    """q: the scan period in time steps (whole, the same for every beam and scan)."""
    period = np.diff(data.time_s, axis=0)
    if period.size == 0:
        raise ParameterError(f"{where}: one scan only; at least two are needed")
    q = int(round(float(period.mean()) / dt_s))
    if q < 1 or np.abs(period - q * dt_s).max() > 1e-6 * dt_s:
        raise ParameterError(f"{where}: the scan period ({float(period.mean()):g} s) is not a whole number of the "
                             f"field's time steps (dt = {dt_s:g} s): make the field with a dt that divides "
                             "it")  # fmt: skip
    return q


def _terms(op, j: int) -> tuple[np.ndarray, int]:
    """Merged terms (T, 5) (component, y, z, shift, weight) of measurement j and its first stored time step, from the
    first scan's operator (the others repeat it)."""
    weight = op.weight[0, j]
    live = weight != 0
    first = int(op.t_index[0, j, live].min())
    rows = {}
    for c in range(3):
        if op.n[j, c] == 0.0:
            continue
        for r in np.flatnonzero(live):
            key = (c, int(op.y_index[j, r]), int(op.z_index[j, r]), int(op.t_index[0, j, r]) - first)
            rows[key] = rows.get(key, 0.0) + op.n[j, c] * weight[r]
    return np.array([(*k, w) for k, w in sorted(rows.items()) if w != 0.0], dtype=float), first


def _mean_los(data: LidarData, ms, times: np.ndarray, run, where: str) -> np.ndarray | None:
    """(n_scan, J) line-of-sight speed [m/s] of the mean wind the dataset added (None: none); a turning one: refused."""
    if not data.mean_wind_added:
        return None
    if data.mean_wind is None:
        return np.broadcast_to(mean_wind_los(ms, run.U_m_s, run.hub_height_m, data.shear_exponent), times.shape)
    wind = MeanWind.from_attrs(data.mean_wind)
    if wind.turns:
        raise ParameterError(f"{where}: its mean wind turns ({wind.describe()}), which turned the measured "
                             "fluctuations' line of sight per height and time; make the dataset without veer or "
                             "directions to constrain a field with it")  # fmt: skip
    return mean_wind_los_series(ms, times, run.U_m_s, run.hub_height_m, wind)


def lidar_streams(run, data: LidarData, sigma: float) -> list:
    """The beam-gates of ``data`` as PlacedStreams of ``run`` (noise sigma [m/s] each)."""
    from turbgen.runs.constrain import PlacedStream

    g = run.grid
    where = f"lidar dataset {data.source}"
    if abs(data.U_m_s - run.U_m_s) > 1e-9 * run.U_m_s:
        raise ParameterError(f"{where}: measured a field with U = {data.U_m_s:g} m/s, this run has U = "
                             f"{run.U_m_s:g} m/s; the probe volume's Taylor shift depends on U: use the same "
                             "U")  # fmt: skip
    if not np.isfinite(data.v_los).any():  # nothing to condition on (an empty reduction further on)
        raise ParameterError(f"{where}: v_los has no value (every line-of-sight value is missing or NaN)")
    ms = measurements_of(lidar_from_mapping(data.lidar, where))
    try:
        planes = check_measurements(SimpleNamespace(grid=g), ms)
    except ParameterError as exc:
        raise ParameterError(f"{where}: {exc}") from None
    beams = sorted({m.beam for m in ms})
    gates = sorted({m.gate for m in ms})
    n_scan = data.v_los.shape[0]
    times = np.stack([data.time_s[:, beams.index(m.beam)] for m in ms], axis=1)
    end = (g.nt - 1) * g.dt_s
    if times.max() + max(m.points_m()[:, 0].max() for m in ms) / run.U_m_s > end + 1e-9 or times.min() < 0:
        raise ParameterError(f"{where}: its measurements fall outside the field's record 0 .. {end:g} s (stored "
                             "time T + x/U)")  # fmt: skip
    q = _scan_step(data, g.dt_s, where)
    if not repeats_every(g, run.U_m_s, ms, times, q, _WEIGHT_TOL):
        raise ParameterError(f"{where}: the measurement times do not repeat every {q} time steps with the same "
                             "weights; the lidar cannot be placed on this grid")  # fmt: skip
    op = los_operator(g, run.U_m_s, ms, planes, times[:1])
    mean = _mean_los(data, ms, times, run, where)
    if g.nt % q:
        raise ParameterError(f"{where}: the scan period ({q} time steps) does not divide the record of {g.nt} steps: "
                             f"make the field with `nt` a multiple of {q}")  # fmt: skip
    out = []
    for j, m in enumerate(ms):
        terms, first = _terms(op, j)
        values = data.v_los[:, beams.index(m.beam), gates.index(m.gate)] - (0.0 if mean is None else mean[:, j])
        series = np.full(g.nt // q, np.nan)
        series[first // q + np.arange(n_scan)] = values
        name = f"{Path(data.source).name}:beam{m.beam}:gate{m.gate}"
        focus = m.points_m()[len(m.offsets_m) // 2]
        out.append(PlacedStream(planes[j], terms, q, first % q, series, sigma, {
            "name": name, "kind": "lidar", "component": "los", "beam": m.beam, "gate": m.gate,
            "x_m": float(g.x_m[planes[j]]), "y_m": float(focus[1]), "z_m": float(focus[2]), "n": list(m.n),
            "plane": planes[j], "noise_m_s": sigma,
            "mean_wind_subtracted": bool(data.mean_wind_added)}))  # fmt: skip
    return out
