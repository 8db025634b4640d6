"""Constraint files: measured point time series a field is conditioned on (schemas/constraints.schema.json).

A file holds sample times (physical time [s] from the start of the field, any rate) and sensors at (x, y, z) (z from the
hub, or height above ground) with any of u, v, w [m/s], null for missing (NaN here). With ``total_wind`` the data hold
the total wind, whose mean (the exports' MeanWind, or the file's ``mean_wind``) is taken off by
:func:`sensor_fluctuations`. turbgen.runs.constrain places the data on the run's grid."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.input_files import CONSTRAINTS, read_input
from turbgen.spec.config import check_mapping, load_schema, parse_document
from turbgen.spec.mean_wind import MeanWind
from turbgen.spec.mean_wind_files import mean_wind_from_options
from turbgen.theory import ranges

COMPONENTS = ("u", "v", "w")


@dataclass(frozen=True, eq=False)
class PointSensor:
    """One sensor: x_m [m upstream], y_m [m], and z_m [m from the hub] or height_m [m above ground] (one of
    them), ``series``: component ("u", "v", "w") -> values [m/s] (NaN: missing), and a sonic's path_m [m] (None: a
    point; only the fit uses it: turbgen.theory.sonic_path). ``plane_x_m``: the plane of a sensor a replay turned into
    the wind's frame (its file's x) where the field has none at its turned ``x_m`` (turbgen.runs.replay)."""

    name: str
    x_m: float
    y_m: float
    z_m: float | None
    height_m: float | None
    series: dict
    path_m: float | None = None
    plane_x_m: float | None = None

    def __post_init__(self):
        if self.path_m is not None and not 0 < self.path_m <= 1:  # the constraints schema's range
            raise ParameterError(f"sensor {self.name}: path_m = {self.path_m:g} m is outside (0, 1] m")


@dataclass(frozen=True, eq=False)
class PointSeries:
    """A constraint file."""

    name: str
    time_s: np.ndarray  # strictly increasing [s]
    sensors: tuple[PointSensor, ...]
    total_wind: bool
    noise_m_s: float | None  # [m/s] (None: not given)
    source: str  # the file
    mean_wind: MeanWind | None = None  # the mean in total-wind data: the file's, else the exports' default

    def __post_init__(self):
        if self.total_wind and self.mean_wind is None:  # the exports' default mean wind
            object.__setattr__(self, "mean_wind", MeanWind())
        if not self.total_wind and self.mean_wind is not None:
            raise ParameterError(f"constraint file {self.source}: a mean wind describes total-wind data; set "
                                 "total_wind")

    def __repr__(self) -> str:
        """What the data are (a notebook cell shows this, not every value): samples, span, kind, the sensors."""
        t = self.time_s
        where = lambda s: f"z {s.z_m:g} m" if s.z_m is not None else f"height {s.height_m:g} m"  # noqa: E731
        sensors = "; ".join(f"{s.name} (x {s.x_m:g} m, y {s.y_m:g} m, {where(s)}: {' '.join(s.series)})"
                            for s in self.sensors)
        kind = "total wind" if self.total_wind else "fluctuations"
        return f"PointSeries {self.name!r}: {t.size} samples, {t[0]:g} to {t[-1]:g} s, {kind}; {sensors}"


def point_series(time_s, sensors, *, total_wind: bool = False, noise_m_s: float | None = None,
                 mean_wind: dict | None = None, name: str = "measured") -> PointSeries:
    """Measured point series made in memory: what a constraint file holds, checked as one is.

    The same object ``turbgen.fit_mann``, ``turbgen.fit_kaimal`` and ``constrain=[...]`` read from a point-series
    JSON or CSV file, from arrays a notebook already has (a logger's pandas columns, say).

    Parameters
    ----------
    time_s : array_like
        Sample times [s] from the start of the field, strictly increasing (any rate).
    sensors : sequence of dict
        One per sensor, with a constraint file's keys: ``name``, ``x_m`` [m upstream], ``y_m`` [m], one of ``z_m``
        [m from the hub] and ``height_m`` [m above ground], optionally ``path_m`` [m] (a sonic's path), and any of
        ``u_m_s``, ``v_m_s``, ``w_m_s``: one value per time [m/s], NaN missing.
    total_wind : bool, optional
        The series hold the total wind (its mean is taken off, as ``mean_wind`` says), not fluctuations.
    noise_m_s : float, optional
        Measurement-noise sigma [m/s] of every value (default: 0 when conditioning).
    mean_wind : dict, optional
        With ``total_wind``: ``profile``, ``veer_deg_per_m``, ``mean_history`` as a file's ``mean_wind``.
    name : str, optional
        What records and messages call the data.

    Returns
    -------
    turbgen.spec.constraints.PointSeries

    Raises
    ------
    ParameterError
        For what a constraint file may not hold (schemas/constraints.schema.json), naming the value.

    Examples
    --------
    >>> import numpy as np, turbgen
    >>> t = np.arange(0.0, 60.0, 0.5)
    >>> mast = turbgen.point_series(t, [dict(name="sonic", x_m=0, y_m=0, z_m=0, u_m_s=np.sin(t), w_m_s=0 * t)])
    >>> mast.sensors[0].name, sorted(mast.sensors[0].series)
    ('sonic', ['u', 'w'])
    """
    where = f"point_series {name!r}"
    time = _array(time_s, "time_s")
    sensors = [_sensor_arrays(s, k) for k, s in enumerate(sensors)]
    keys = {k: v for k, v in (("noise_m_s", noise_m_s), ("mean_wind", mean_wind)) if v is not None}
    most = load_schema("constraints")["properties"]["time_s"]["maxItems"]
    if time.size > most:
        raise ParameterError(f"{where}: time_s holds {time.size} samples (at most {most})")
    # the schema checks the keys and types on the series' first values (the rest are floats by construction)
    check_mapping({"kind": "point-series", "name": name, "time_s": _head(time), "total_wind": total_wind, **keys,
                   "sensors": [{k: _head(v) for k, v in s.items()} for s in sensors]}, "constraints", where)
    return point_series_from_mapping({"name": name, "time_s": time, "sensors": sensors, "total_wind": total_wind,
                                      **keys}, f"(in memory) {name}", where=where, checked=True)


def _schema_view(data):
    """``data`` with each number list (``time_s``; a series, None missing) cut to its first two values, so the schema
    checks a 20 Hz record's keys and types without walking its 10^5 values one by one; ``data`` itself when a list
    holds anything else or is over the sample limit (the full check then names the value)."""
    most = load_schema("constraints")["properties"]["time_s"]["maxItems"]

    def cut(v, allowed=frozenset((int, float))):
        if not (isinstance(v, list) and len(v) <= most and set(map(type, v)) <= allowed):
            raise TypeError
        return v[:2]

    try:
        sensors = [{k: cut(v, frozenset((int, float, type(None)))) if k.endswith("_m_s") else v for k, v in s.items()}
                   for s in data["sensors"]]
        return {**data, "time_s": cut(data["time_s"]), "sensors": sensors}
    except (TypeError, KeyError, AttributeError):
        return data


def _sensor_arrays(sensor, k: int) -> dict:
    """A sensor's mapping with its series as float arrays (NaN missing)."""
    if not hasattr(sensor, "items"):
        raise ParameterError(f"point_series: sensors[{k}] must be a dict of a sensor's keys, not "
                             f"{type(sensor).__name__}")
    return {key: _array(v, f"sensors[{k}] {key}") if key.endswith("_m_s") else v for key, v in sensor.items()}


def _head(value):
    """An array's first two values as the file's list (None for NaN); other values as they are."""
    return [None if math.isnan(x) else x for x in value[:2].tolist()] if isinstance(value, np.ndarray) else value


def _array(values, where: str) -> np.ndarray:
    """``values`` as a 1-D float array; ParameterError naming ``where`` otherwise."""
    try:
        a = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"point_series: {where} must be numbers") from None
    if a.ndim != 1:
        raise ParameterError(f"point_series: {where} must be one-dimensional, not of shape {a.shape}")
    return a


def point_series_from_mapping(data, source: str, where: str | None = None, checked: bool = False) -> PointSeries:
    """A PointSeries from a schema-valid mapping (``checked``: already checked, its series may be float arrays);
    ParameterError naming ``where`` (default: the file ``source``) for any bad content."""
    where = where or f"constraint file {source}"
    if not checked:
        check_mapping(_schema_view(data), "constraints", where)
    t = np.asarray(data["time_s"], dtype=float)
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ParameterError(f"{where}: time_s must be finite and strictly increasing")
    sensors = []
    for k, s in enumerate(data["sensors"]):
        name = s.get("name", f"sensor {k}")
        series = {}
        for c in [c for c in COMPONENTS if f"{c}_m_s" in s]:
            v = s[f"{c}_m_s"]
            v = v if isinstance(v, np.ndarray) else np.array([math.nan if x is None else x for x in v], dtype=float)
            if len(v) != len(t):
                raise ParameterError(f"{where}: {name} {c}_m_s has {len(v)} values for {len(t)} times")
            ranges.check_values("measured_m_s", v, f"{where}: {name} {c}_m_s")
            if not np.isfinite(v).any():
                raise ParameterError(f"{where}: {name} {c}_m_s has no value (all missing)")
            series[c] = v
        sensors.append(PointSensor(name, float(s["x_m"]), float(s["y_m"]), s.get("z_m"), s.get("height_m"), series,
                                   s.get("path_m")))
    total = bool(data.get("total_wind", False))
    return PointSeries(data.get("name", Path(source).stem), t, tuple(sensors), total, data.get("noise_m_s"), source,
                       mean_wind_spec(data.get("mean_wind"), total, where, Path(source).parent))  # fmt: skip


def mean_wind_spec(spec, total: bool, where: str, folder: Path) -> MeanWind | None:
    """The file's ``mean_wind`` (files relative to ``folder``), else the default; None without ``total``."""
    if spec is not None and not total:
        raise ParameterError(f"{where}: mean_wind describes total-wind data; set total_wind true or drop it")
    if not total:
        return None
    spec = spec or {}
    profile, history = spec.get("profile"), spec.get("mean_history")
    if profile is not None and profile.partition(":")[0].strip().lower() == "table":
        profile = "table:" + str(folder / profile.partition(":")[2].strip())
    try:
        wind = mean_wind_from_options(profile, spec.get("veer_deg_per_m"),
                                      None if history is None else folder / history)
    except ParameterError as exc:
        raise ParameterError(f"{where}: mean_wind: {exc}") from None
    return wind or MeanWind()


def sensor_fluctuations(f: PointSeries, s: PointSensor, U_m_s: float, hub_height_m: float) -> tuple[dict, float]:
    """The sensor's series as fluctuations [m/s] (component -> series), and the time-mean of the mean u removed [m/s].

    With ``total_wind``, the mean wind (:meth:`MeanWind.fluctuation_uv`) at the sensor's height and y and at the
    stored time T + x / U (as the periodic exports use it) is taken from u, and from v when it turns (a value missing
    in u or v is then missing in both). ParameterError when it turns and the sensor lacks u or v, or the profile
    does not cover its height."""
    if not f.total_wind:
        return dict(s.series), 0.0
    where = f"constraint file {f.source}, {s.name}"
    wind = f.mean_wind
    height = s.height_m if s.height_m is not None else hub_height_m + s.z_m
    if wind.turns and ("u" in s.series) != ("v" in s.series):
        raise ParameterError(f"{where}: the mean wind turns ({wind.describe()}), which mixes u and v: give both for "
                             "total-wind data")
    stored = f.time_s + s.x_m / U_m_s
    u = s.series.get("u", np.zeros_like(stored))
    v = s.series.get("v")
    try:
        fu, fv = wind.fluctuation_uv(u, v, stored, s.y_m, height, U_m_s, hub_height_m)
        removed = float(np.mean(wind.hub_history(stored, U_m_s)[0]) * wind.speed_ratio(height, hub_height_m))
    except ParameterError as exc:
        raise ParameterError(f"{where}: {exc}") from None
    out = dict(s.series)
    if "u" in s.series:
        out["u"] = fu
    if wind.turns and "v" in s.series:
        out["v"] = fv
    return out, removed if "u" in s.series else 0.0


def load_point_series(path) -> PointSeries:
    """Read and check a constraint file (JSON, or CSV: turbgen.spec.point_csv); ParameterError if it cannot be read,
    is not a regular file, not JSON, nested too deeply, fails the schema or holds inconsistent values."""
    p = Path(path)
    if p.suffix.lower() == ".csv":
        from turbgen.spec.point_csv import read_point_csv

        return read_point_csv(p)
    data = parse_document(read_input(p, CONSTRAINTS), "JSON", f"constraint file {p}")
    return point_series_from_mapping(data, str(p))


# the keys of a Mann run mapping (schemas/mann-run.schema.json) that condition the field; MannRun itself is the prior
CONSTRAINT_KEYS = ("constrain", "noise_m_s", "conditional_mean", "fit")
MAX_NOISE_M_S = 100.0  # the schemas' maximum of noise_m_s


@dataclass(frozen=True)
class ConstraintRequest:
    """What a run mapping asks to condition the field on: ``files`` (paths, or loaded PointSeries /
    LidarData), ``noise_m_s`` [m/s] (None: each file's own), ``conditional_mean`` (the conditional mean
    instead of a conditional sample), ``fit`` (replay: the model fitted to the files first, turbgen.runs.replay)."""

    files: tuple
    noise_m_s: float | None = None
    conditional_mean: bool = False
    fit: bool = False


def split_constraint_keys(mapping: dict) -> tuple[dict, ConstraintRequest | None]:
    """(the run mapping without the constraint keys, its ConstraintRequest or None without ``constrain``);
    ParameterError for ``noise_m_s``, ``conditional_mean`` or ``fit`` without ``constrain``, or a bad noise."""
    rest = {k: v for k, v in mapping.items() if k not in CONSTRAINT_KEYS}
    files = mapping.get("constrain") or ()
    if isinstance(files, (str, Path)) or not isinstance(files, (list, tuple)):
        files = (files,) if files else ()
    noise, mean, fit = mapping.get("noise_m_s"), bool(mapping.get("conditional_mean")), bool(mapping.get("fit"))
    if not files:
        if fit:
            raise ParameterError("fit (--fit) needs constrain (--constrain DATA): the data to fit and replay")
        if noise is not None or mean:
            raise ParameterError("a measurement noise (noise_m_s) or conditional_mean needs constraints: give "
                                  "constrain (--constrain FILE)")
        return rest, None
    return rest, ConstraintRequest(tuple(files), check_noise(noise), mean, fit)


def check_noise(noise) -> float | None:
    """``noise`` [m/s] as a float (None stays None); ParameterError unless a finite number in [0, MAX_NOISE_M_S]."""
    if noise is not None and (isinstance(noise, bool) or not isinstance(noise, (int, float))
                              or not (math.isfinite(noise) and 0 <= noise <= MAX_NOISE_M_S)):  # fmt: skip
        raise ParameterError(f"noise = {noise!r} m/s must be a finite number in [0, {MAX_NOISE_M_S:g}]")
    return None if noise is None else float(noise)


def resolve_constraint_paths(mapping: dict, base_dir) -> dict:
    """``mapping`` with relative ``constrain`` and ``spectrum`` paths under ``base_dir`` (the run file's folder)."""
    base = Path(base_dir)
    spectrum = mapping.get("spectrum")
    if isinstance(spectrum, str) and not Path(spectrum).is_absolute():
        mapping = {**mapping, "spectrum": str(base / spectrum)}
    files = mapping.get("constrain")
    if not isinstance(files, list):
        return mapping
    return {**mapping, "constrain": [str(base / f) if isinstance(f, str) and not Path(f).is_absolute() else f
                                     for f in files]}  # fmt: skip
