"""Replay a measured event (``turbgen mann --constrain DATA --fit``): the Mann model and mean wind fitted to DATA,
then the field conditioned on the same data with them.

The fitted ae, L and Gamma (rounded to FIT_DIGITS digits, so a fit's last bits never change the field) replace the
run's; typed ones are refused; the run's lifetime is the fit's. A lidar record's fit holds Gamma (a given one) and
keeps the record's U and mean wind. Sensors (or range gates) at two or more x fit the eddy-evolution time too (Guo
et al. 2022); when the data identify it (the frozen limit outside its interval) it is the run's, and a typed one is
refused. Without a typed U, U is the fitted hub speed. The store's ``fit`` attribute records the fit, the files'
SHA-256 and the ``turbgen export`` options of that mean wind."""

from __future__ import annotations

import hashlib
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.spec.constraints import PointSeries
from turbgen.spec.mann import MannRun
from turbgen.theory.mean_wind import rotate_horizontal
from turbgen.validation.fit.data import data_from_points
from turbgen.validation.fit.evolution import with_evolution
from turbgen.validation.fit.mann import fit_mann_data
from turbgen.validation.fit.mean_wind import fit_mean_wind, hub_direction_deg
from turbgen.virtual_lidar.dataset import LidarData
from turbgen.virtual_lidar.fit import fit_lidar

FIT_DIGITS = 6
TURN_DECIMALS = 6  # the turn into the data's mean wind [deg], rounded as the fitted values (4e-7 m/s at 20 m/s)
MIN_MOVE_M = 0.01  # a sensor that turn moves less stays: a position is not known to better than a centimetre
FITTED = {"ae": "ae", "length_scale_m": "L", "gamma": "gamma"}  # run key -> option
REFUSED = ("L", "gamma", "ae", "sigma_u", "ti")  # options --fit sets (the energy level among them)


def check_fit_options(given: dict, prefix: str = "--", lidar: bool = False) -> None:
    """Refuse, in one line, the options ``--fit`` sets (``given``: option name -> value, None: not given); of a
    ``lidar`` record the fit holds Gamma, so a given one is the value held."""
    typed = [f"{prefix}{n.replace('_', '-') if prefix == '--' else n}" for n in REFUSED
             if given.get(n) is not None and not (lidar and n == "gamma")]
    if typed:
        sets = "L and the energy level (gamma held)" if lidar else "L, gamma and the energy level"
        raise ParameterError(f"{', '.join(typed)} with --fit (fit=True): the fit sets {sets} from the data; drop "
                             "them, or drop --fit")


def _sha256(source: str) -> str | None:
    p = Path(source)
    return hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else None


def fitted_inputs(mapping: dict, constraints: list, nperseg: int | None = None,
                  evo_typed: bool = False) -> tuple[dict, list, dict]:
    """(the run mapping with the fitted parameters, the constraints with the fitted mean wind, the ``fit`` record).
    Point-series files are fitted as one; ParameterError for a lidar record with other files, a flagged fit,
    ``evo_typed`` (an evolution time given) when the data identify one, and the fit's own refusals."""
    if any(isinstance(c, LidarData) for c in constraints) and len(constraints) > 1:
        raise ParameterError(f"--fit (fit=True) fits a lidar record alone; got {len(constraints)} constraint files: "
                             "fit them apart (turbgen fit mann) and give the values")
    if mapping.get("factor1", 1.0) != 1.0:
        raise ParameterError(f"--fit with factor1 = {mapping['factor1']}: the fit's tables hold the lifetime with "
                             "factor1 = 1 only (Guo et al. 2023, Eq. 7)")
    lidar = isinstance(constraints[0], LidarData)
    fit, constraints, export, speed, turn = (_lidar_fit if lidar else _points_fit)(mapping, constraints, nperseg)
    values = {k: float(f"{getattr(fit, k).value:.{FIT_DIGITS}g}") for k in FITTED} | _evolution(fit, evo_typed)
    out = {k: v for k, v in mapping.items() if k not in ("sigma_u_m_s", "ti")} | values | {"lifetime": fit.lifetime}
    out["ae_from"] = f"fitted to {', '.join(Path(c.source).name for c in constraints)} (turbgen fit mann)"
    out.setdefault("U_m_s", speed)
    run = {k: out[k] for k in (*FITTED, "U_m_s", "lifetime", *values.keys() - FITTED.keys())}
    files = [{"path": c.source, "sha256": _sha256(c.source)} for c in constraints]
    record = {"fit": fit.to_dict(), "run": run, "files": files, "export": export}
    return out, constraints, record | ({} if turn is None else {"turned_deg": turn} | _placed(constraints))


def _placed(series: list) -> dict:
    """``{"placed": {sensor: [x, y]}}``: the sensors :func:`_turned` moved, at their positions in the wind's frame
    [m]; {} if none moved."""
    moved = {s.name: [s.x_m, s.y_m] for ps in series for s in ps.sensors if s.plane_x_m is not None}
    return {"placed": moved} if moved else {}


def _reliable(fit, source: str):
    """``fit``, or ParameterError naming its flags."""
    if fit.flags:
        raise ParameterError(f"--fit: the fit of {source} is not reliable: {'; '.join(fit.flags)}")
    return fit


def _points_fit(mapping: dict, series: list, nperseg: int | None) -> tuple:
    """(the fit with its evolution time and mean wind, the series with the fitted mean wind, the export options of
    that mean wind, the fitted hub speed [m/s], the turn [deg]) of point-series files, fitted as one
    (:func:`_merged`). The field's x is the data's mean wind direction at the hub: total-wind u, v are turned by
    minus that direction (:func:`_turned`; the rest of the direction is the fitted veer)."""
    ps = _merged(series)
    data = data_from_points(ps, None if ps.total_wind else mapping.get("U_m_s"))
    fit = with_evolution(data, _reliable(fit_mann_data(data, nperseg, lifetime=mapping.get("lifetime")), ps.source))
    hub = MannRun.from_mapping(mapping).hub_height_m
    mean = fit_mean_wind(ps, hub)
    turn = round(hub_direction_deg(ps, hub), TURN_DECIMALS) if ps.total_wind else None
    if turn:
        series = [_turned(s, turn) for s in series]
        ps = _merged(series)
    speed = float(f"{mean.U_hub_m_s or _hub_speed(ps, hub) or fit.U_m_s:.{FIT_DIGITS}g}")
    export = mean.export_options()
    if ps.total_wind and export:
        wind = ps.mean_wind
        if "profile" in export:
            wind = replace(wind, profile="power", shear_exponent=float(export["profile"][6:]), roughness_m=None,
                           displacement_m=0.0, table_heights_m=(), table_speeds_m_s=(), table_directions_deg=(),
                           table_label="")
        wind = replace(wind, veer_deg_per_m=export.get("veer_deg_per_m", wind.veer_deg_per_m))
        series = [replace(s, mean_wind=wind) for s in series]
    return replace(fit, mean_wind=mean), series, export, speed, turn


def _turned(ps: PointSeries, deg: float) -> PointSeries:
    """``ps`` in the wind's frame: every sensor's (u, v) turned by ``-deg`` (a value missing in either is missing in
    both; a sensor lacking u or v, a cup's speed, keeps its series), and its (x, y) about the field's origin as the fit
    turns them (turbgen.validation.fit.data.in_wind_frame). A sensor moved by MIN_MOVE_M or more goes to its turned
    position to the centimetre, keeping its file's x as ``plane_x_m``; a smaller move is none (a position is not known
    better: a mast's booms turned by a hundredth of a degree stay where they are)."""
    sensors = []
    for s in ps.sensors:
        series = s.series | dict(zip("uv", rotate_horizontal(s.series["u"], s.series["v"], -deg))) \
            if {"u", "v"} <= s.series.keys() else s.series
        x, y = (float(v) for v in rotate_horizontal(s.x_m, s.y_m, -deg))
        moved = math.hypot(x - s.x_m, y - s.y_m) >= MIN_MOVE_M
        sensors.append(replace(s, series=series, **({"x_m": round(x, 2), "y_m": round(y, 2), "plane_x_m": s.x_m}
                                                     if moved else {})))
    return replace(ps, sensors=tuple(sensors))


def _merged(series: list) -> PointSeries:
    """Point-series files as one, their sensors side by side (two masts' files, say); ParameterError unless they
    share the sample times, total_wind and mean wind, or if a sensor name repeats."""
    first = series[0]
    for ps in series[1:]:
        if not (np.array_equal(ps.time_s, first.time_s) and (ps.total_wind, ps.mean_wind) == (first.total_wind,
                                                                                              first.mean_wind)):
            raise ParameterError(f"--fit of {first.source} and {ps.source}: files fitted together must share time_s, "
                                 "total_wind and mean_wind (resample them onto one clock)")
    names = [s.name for ps in series for s in ps.sensors]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if len(series) > 1 and repeated:
        raise ParameterError(f"--fit of {len(series)} files: the sensor name(s) {', '.join(map(repr, repeated))} "
                             "repeat; name each sensor once")
    return replace(first, sensors=tuple(s for ps in series for s in ps.sensors),
                   source=" + ".join(ps.source for ps in series))


def _lidar_fit(mapping: dict, records: list, nperseg: int | None) -> tuple:
    """As :func:`_points_fit` for a lidar record: ae, L and the evolution time from its line-of-sight spectra and
    gates, Gamma held (the run's, default MANN_DEFAULTS), the mean wind the record's, U the record's."""
    ld = records[0]
    if mapping.get("lifetime", "guo") != "guo":
        raise ParameterError(f"--fit of the lidar record {ld.source} with lifetime = {mapping['lifetime']!r}: the "
                             "lidar fit's model has Guo's lifetime only; drop the lifetime")
    return _reliable(fit_lidar(ld, nperseg, mapping.get("gamma")), ld.source), records, {}, ld.U_m_s, None


def _evolution(fit, evo_typed: bool) -> dict:
    """{"evo_time_s": the fitted evolution time, rounded} when the data identify it, else {}; ParameterError for
    ``evo_typed`` then (the data set it, as L)."""
    e = fit.evolution
    if e is None or not e.identified:
        return {}
    if evo_typed:
        raise ParameterError(f"--evo with --fit (fit=True): the data along x identify the eddy-evolution time "
                             f"({e.value_s:.4g} s, 95 % [{e.ci95[0]:.4g}, {e.ci95[1]:.4g}]); drop --evo, or drop --fit")
    return {"evo_time_s": float(f"{e.value_s:.{FIT_DIGITS}g}")}


def _hub_speed(ps: PointSeries, hub: float) -> float | None:
    """The hub speed [m/s] at which the file's own mean wind meets the sensors' mean u (None: fluctuation data)."""
    if not ps.total_wind:
        return None
    s = [s for s in ps.sensors if "u" in s.series]
    h = np.array([x.height_m if x.height_m is not None else hub + x.z_m for x in s])
    return float(np.mean([np.nanmean(x.series["u"]) for x in s] / ps.mean_wind.speed_ratio(h, hub)))


def describe_fit(record: dict) -> list[str]:
    """Lines saying what a store's ``fit`` record fitted and applied."""
    f, run = record["fit"], record["run"]
    ci = lambda k: "held" if f[k]["ci95"] is None else f"[{f[k]['ci95'][0]:.4g}, {f[k]['ci95'][1]:.4g}]"  # noqa: E731
    lines = [f"fitted to {', '.join(Path(x['path']).name for x in record['files'])}: L {run['length_scale_m']:g} m "
             f"{ci('length_scale_m')}, gamma {run['gamma']:g} {ci('gamma')}, ae {run['ae']:g} {ci('ae')} (95 %), "
             f"chi2/dof {f['chi2_dof']:.3g}; U {run['U_m_s']:g} m/s, {run.get('lifetime', 'guo')} lifetime"]
    mean = [f"{k} {f[k]['value']:.4g}" for k in ("shear_exponent", "veer_deg_per_m", "turbulence_intensity")
            if f.get(k, {}).get("value") is not None]
    e = f.get("evo_time_s") or {}
    if "evo_time_s" in run:
        lines.append(f"eddy-evolution time {run['evo_time_s']:g} s [{e['ci95'][0]:.4g}, {e['ci95'][1]:.4g}] (95 %), "
                     "fitted to the u coherence along x")
    elif e.get("held") is False:
        lines.append("eddy-evolution time not identified by the data (the frozen limit is inside its 95 % interval): "
                     "the run's")
    if record.get("turned_deg"):
        lines.append(f"the data's mean wind direction at the hub, {record['turned_deg']:+.4g} deg (counter-clockwise "
                     "from above), is the field's x: their u and v were turned by minus that")
    if record.get("placed"):
        at = [f"{k} ({x:.6g}, {y:.6g})" for k, (x, y) in record["placed"].items()]
        lines.append(f"the sensors' x and y were turned too: {', '.join(at[:4])}{', ...' if len(at) > 4 else ''} m in "
                     "the wind's frame (a sensor whose turned x is no plane stays on its file x's plane, delayed by "
                     "its turned x / U)")
    exp = " ".join(f"--{k.split('_')[0]} {v}" for k, v in record["export"].items())
    return lines + ([f"fitted mean wind: {', '.join(mean)}" + (f" (turbgen export uses {exp})" if exp else "")]
                    if mean else [])
