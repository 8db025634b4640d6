"""Measured point series as a CSV file: one row per sample time, one column per sensor and component, the sensors'
positions and the file's keys in ``#`` header lines (docs/constrained-fields.md). It is read into the mapping of
the JSON format (schemas/constraints.schema.json) and checked as that is, so both give the same PointSeries."""

from __future__ import annotations

import csv
import math
from pathlib import Path

from turbgen.errors import ParameterError
from turbgen.input_files import CONSTRAINTS, CSV_FILE, check_input, read_input_text

FILE_KEYS = {"name": str, "total_wind": bool, "noise_m_s": float}
MEAN_WIND_KEYS = {"profile": str, "veer_deg_per_m": float, "mean_history": str}
SENSOR_KEYS = ("x_m", "y_m", "z_m", "height_m", "path_m")
COMPONENT_COLUMNS = ("u_m_s", "v_m_s", "w_m_s")


def is_point_csv(path) -> bool:
    """Whether ``path`` is a CSV file whose header declares sensors (``# sensor NAME = ...``): a point-series CSV,
    not a line-of-sight one."""
    if Path(path).suffix.lower() != ".csv":
        return False
    with open(check_input(path, CSV_FILE), "rb") as f:  # a regular file of either kind: its header only
        return declares_sensors(f.read(1 << 16).decode("utf-8", "replace").splitlines())


def declares_sensors(lines) -> bool:
    """Whether a CSV file's ``lines`` hold a ``# sensor NAME = ...`` header line (a point-series CSV)."""
    return any(line.startswith("#") and line.lstrip("#").strip().startswith("sensor ") for line in lines)


def _number(text: str, where: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ParameterError(f"{where}: {text.strip()!r} is not a number") from None


def _header(lines: list[str], where: str) -> tuple[dict, dict]:
    """(the file's keys as the JSON mapping's, sensor name -> its position keys) of the ``#`` lines."""
    doc, sensors = {"kind": "point-series"}, {}
    for line in lines:
        key, sep, value = line.lstrip("#").partition("=")
        key = key.strip()
        if not sep or not key:
            continue  # a comment
        if key.startswith("sensor "):
            name = key[len("sensor "):].strip()
            spec = {k.strip(): v for k, v in (item.partition("=")[::2] for item in value.split(","))}
            unknown = sorted(set(spec) - set(SENSOR_KEYS))
            if not name or name in sensors or unknown:
                bad = f" (not {', '.join(unknown)})" if unknown else ""
                raise ParameterError(f"{where}: sensor line {line.strip()!r}: give a new name and "
                                     f"{', '.join(SENSOR_KEYS)} as key = value{bad}")
            if not {"x_m", "y_m"} <= set(spec) or ("z_m" in spec) == ("height_m" in spec):
                raise ParameterError(f"{where}: sensor {name!r} needs x_m, y_m and one of z_m, height_m")
            sensors[name] = {"name": name, **{k: _number(v, f"{where}, sensor {name} {k}") for k, v in spec.items()}}
        elif key in FILE_KEYS or key in MEAN_WIND_KEYS:
            keys = FILE_KEYS if key in FILE_KEYS else MEAN_WIND_KEYS
            parsed = _number(value, f"{where}, {key}") if keys[key] is float else value.strip()
            if keys[key] is bool:
                if parsed.lower() not in ("true", "false"):
                    raise ParameterError(f"{where}: {key} = {parsed!r} must be true or false")
                parsed = parsed.lower() == "true"
            (doc if key in FILE_KEYS else doc.setdefault("mean_wind", {}))[key] = parsed
        else:
            allowed = ", ".join([*FILE_KEYS, *MEAN_WIND_KEYS, "sensor NAME"])
            raise ParameterError(f"{where}: unknown header key {key!r} (allowed: {allowed})")
    return doc, sensors


def point_csv_mapping(text: str, where: str) -> dict:
    """The JSON format's mapping of a point-series CSV file's ``text``; ParameterError naming ``where``."""
    lines = text.splitlines()
    doc, sensors = _header([line for line in lines if line.startswith("#")], where)
    reader = csv.reader(line for line in lines if line.strip() and not line.startswith("#"))
    names = [c.strip() for c in next(reader, [])]
    if not names or names[0] != "time_s":
        raise ParameterError(f"{where}: the first column must be time_s (found {names[0] if names else 'none'})")
    columns = []
    for name in names[1:]:
        sensor, _, component = name.rpartition(":")
        if sensor not in sensors or component not in COMPONENT_COLUMNS or (sensor, component) in columns:
            raise ParameterError(f"{where}: column {name!r} is not SENSOR:u_m_s, v_m_s or w_m_s of a sensor declared "
                                 f"once in a '# sensor NAME = x_m=.., y_m=.., height_m=..' line ({', '.join(sensors)})")
        columns.append((sensor, component))
    rows = []
    for n, row in enumerate(reader, start=2):
        if len(row) != len(names):
            raise ParameterError(f"{where}: data row {n} has {len(row)} values, {len(names)} expected")
        values = [None if not v.strip() else _number(v, f"{where}, data row {n}") for v in row]
        rows.append([None if v is None or math.isnan(v) else v for v in values])
    for k, (sensor, component) in enumerate(columns, start=1):
        sensors[sensor][component] = [r[k] for r in rows]
    empty = [name for name, s in sensors.items() if not set(s) & set(COMPONENT_COLUMNS)]
    if empty:
        raise ParameterError(f"{where}: sensor {empty[0]!r} has no column (give NAME:u_m_s, v_m_s or w_m_s)")
    return {**doc, "time_s": [r[0] for r in rows], "sensors": list(sensors.values())}


def read_point_csv(path):
    """The PointSeries of a point-series CSV file (turbgen.spec.constraints.point_series_from_mapping checks it as
    a JSON file's); ParameterError for an unreadable or invalid file."""
    from turbgen.spec.constraints import point_series_from_mapping

    where = f"constraint file {path}"
    return point_series_from_mapping(point_csv_mapping(read_input_text(path, CONSTRAINTS), where), str(path))
