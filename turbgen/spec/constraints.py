"""Constraint files: measured point time series a field is conditioned on (schemas/constraints.schema.json).

    series = load_point_series("mast.json")

A file holds the sample times (physical time [s] from the start of the field, any rate) and one or more sensors at
(x, y, z) (z relative to the hub, or height above ground) with any of u, v, w [m/s]; missing values are null (NaN
here). ``total_wind`` says u is the total wind speed (the run's mean wind U is subtracted when it is placed on the
grid); v and w are always fluctuations. turbgen.runs.constrain places the data on the run's grid.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.spec.config import check_mapping

COMPONENTS = ("u", "v", "w")


@dataclass(frozen=True, eq=False)
class PointSensor:
    """One sensor: position x_m [m upstream], y_m [m], z_m [m from the hub] or height_m [m above ground] (exactly one
    of them not None), and ``series``: component ("u", "v", "w") -> values [m/s] (NaN: missing)."""

    name: str
    x_m: float
    y_m: float
    z_m: float | None
    height_m: float | None
    series: dict


@dataclass(frozen=True, eq=False)
class PointSeries:
    """A constraint file: ``time_s`` (strictly increasing) [s], ``sensors``, ``total_wind`` (u holds U + u'),
    ``noise_m_s`` [m/s] (None: not given), ``source`` (the file, for messages and the store)."""

    name: str
    time_s: np.ndarray
    sensors: tuple[PointSensor, ...]
    total_wind: bool
    noise_m_s: float | None
    source: str


def point_series_from_mapping(data, source: str) -> PointSeries:
    """A PointSeries from a schema-valid mapping; ParameterError naming ``source`` for any bad content."""
    check_mapping(data, "constraints", f"constraint file {source}")
    where = f"constraint file {source}"
    t = np.asarray(data["time_s"], dtype=float)
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ParameterError(f"{where}: time_s must be finite and strictly increasing")
    sensors = []
    for k, s in enumerate(data["sensors"]):
        name = s.get("name", f"sensor {k}")
        series = {}
        for c in COMPONENTS:
            if f"{c}_m_s" not in s:
                continue
            v = np.array([math.nan if x is None else x for x in s[f"{c}_m_s"]], dtype=float)
            if len(v) != len(t):
                raise ParameterError(f"{where}: {name} {c}_m_s has {len(v)} values for {len(t)} times")
            if not np.isfinite(v).any():
                raise ParameterError(f"{where}: {name} {c}_m_s has no value (all missing)")
            series[c] = v
        sensors.append(PointSensor(name, float(s["x_m"]), float(s["y_m"]), s.get("z_m"), s.get("height_m"), series))
    return PointSeries(data.get("name", Path(source).stem), t, tuple(sensors), bool(data.get("total_wind", False)),
                       data.get("noise_m_s"), source)  # fmt: skip


def load_point_series(path) -> PointSeries:
    """Read and check a constraint file (JSON, schemas/constraints.schema.json).

    Raises
    ------
    ParameterError
        If the file cannot be read, is not JSON, does not satisfy the schema, or holds inconsistent values.
    """
    p = Path(path)
    try:
        data = json.loads(p.read_bytes())
    except OSError as exc:
        raise ParameterError(f"constraint file {p}: cannot read it ({exc.strerror or exc})") from None
    except ValueError as exc:
        raise ParameterError(f"constraint file {p}: not valid JSON ({str(exc).splitlines()[0]})") from None
    return point_series_from_mapping(data, str(p))


# the keys of a Mann run mapping (schemas/mann-run.schema.json) that condition the field; MannRun itself is the prior
CONSTRAINT_KEYS = ("constrain", "noise_m_s", "conditional_mean")


@dataclass(frozen=True)
class ConstraintRequest:
    """What a run mapping asks to condition the field on: ``files`` (paths, or constraints already loaded:
    PointSeries / turbgen.lidar.dataset.LidarData), ``noise_m_s`` [m/s] (None: each file's own) and
    ``conditional_mean`` (write the conditional mean instead of a conditional sample)."""

    files: tuple
    noise_m_s: float | None = None
    conditional_mean: bool = False


def split_constraint_keys(mapping: dict) -> tuple[dict, ConstraintRequest | None]:
    """(the run mapping without the constraint keys, the ConstraintRequest or None when ``constrain`` is absent or
    empty).

    Raises
    ------
    ParameterError
        For ``noise_m_s`` or ``conditional_mean`` without ``constrain``, a ``constrain`` that is not a list, a
        negative or non-finite ``noise_m_s``.
    """
    rest = {k: v for k, v in mapping.items() if k not in CONSTRAINT_KEYS}
    files = mapping.get("constrain") or ()
    if isinstance(files, (str, Path)) or not isinstance(files, (list, tuple)):
        files = (files,) if files else ()
    noise, mean = mapping.get("noise_m_s"), bool(mapping.get("conditional_mean", False))
    if not files:
        if noise is not None or mean:
            raise ParameterError("a measurement noise (noise_m_s) or conditional_mean needs constraints: give "
                                  "constrain (--constrain FILE)")
        return rest, None
    if noise is not None and (isinstance(noise, bool) or not isinstance(noise, (int, float))
                              or not (math.isfinite(noise) and noise >= 0)):  # fmt: skip
        raise ParameterError(f"noise = {noise!r} m/s must be a finite number >= 0")
    return rest, ConstraintRequest(tuple(files), None if noise is None else float(noise), mean)


def resolve_constraint_paths(mapping: dict, base_dir) -> dict:
    """``mapping`` with the relative paths of its ``constrain`` list taken from ``base_dir`` (a run file's paths
    are relative to the run file)."""
    files = mapping.get("constrain")
    if not isinstance(files, list):
        return mapping
    base = Path(base_dir)
    return {**mapping, "constrain": [str(base / f) if isinstance(f, str) and not Path(f).is_absolute() else f
                                     for f in files]}  # fmt: skip
