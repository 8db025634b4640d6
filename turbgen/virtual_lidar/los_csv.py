"""Measured line-of-sight data as a plain CSV file, for ``turbgen mann --constrain FILE.csv``.

The format (header keys lidar, U_m_s, total_wind, profile, mean_history; columns time_s, beam, gate, v_los_m_s)
is in docs/constrained-fields.md; the result is the same LidarData as a ``turbgen lidar --out`` dataset's."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.input_files import LINE_OF_SIGHT, read_input_text
from turbgen.virtual_lidar.dataset import LidarData
from turbgen.virtual_lidar.description import load_lidar
from turbgen.virtual_lidar.run import lidar_attrs
from turbgen.spec.constraints import mean_wind_spec

COLUMNS = ("time_s", "beam", "gate", "v_los_m_s")
HEADER_KEYS = ("lidar", "U_m_s", "total_wind", "profile", "mean_history")


def is_los_csv(path) -> bool:
    """Whether ``path`` names a CSV file (by its suffix)."""
    return Path(path).suffix.lower() == ".csv"


def parse_header(lines: list[str], where: str) -> dict:
    """The HEADER_KEYS of the comment lines ``lines`` (``# key = value``; other comments ignored) as strings."""
    keys = {}
    for line in lines:
        key, sep, value = line.lstrip("#").partition("=")
        key = key.strip()
        if not sep or not key:
            continue  # a comment
        if key not in HEADER_KEYS:
            raise ParameterError(f"{where}: unknown header key {key!r} (allowed: {', '.join(HEADER_KEYS)})")
        keys[key] = value.strip()
    return keys


def parse_table(text: list[str], where: str) -> tuple[dict, np.ndarray]:
    """(header, table (n, 4) of COLUMNS) of a CSV file's lines ``text``; ParameterError naming ``where``."""
    comments = [line for line in text if line.startswith("#")]
    body = [line for line in text if line.strip() and not line.startswith("#")]
    reader = csv.reader(body)
    names = [c.strip() for c in next(reader, [])]
    if tuple(names) != COLUMNS:
        raise ParameterError(f"{where}: the columns must be {','.join(COLUMNS)} (found {','.join(names) or 'none'})")
    values = []
    for n, row in enumerate(reader, start=2):
        if len(row) != 4:
            raise ParameterError(f"{where}: data row {n} has {len(row)} values, 4 expected")
        try:
            values.append([float(v) if v.strip() else math.nan for v in row])
        except ValueError:
            raise ParameterError(f"{where}: data row {n} holds a value that is not a number: {row}") from None
    if not values:
        raise ParameterError(f"{where}: no data rows")
    return parse_header(comments, where), np.array(values)


def _grid(table: np.ndarray, n_beams: int, n_gates: int, where: str) -> tuple[np.ndarray, np.ndarray]:
    """v_los (scan, beam, gate) and time_s (scan, beam) of the rows."""
    t, beam, gate, v = table.T
    for name, col, n in (("beam", beam, n_beams), ("gate", gate, n_gates)):
        bad = ~np.isfinite(col) | (col != np.round(col)) | (col < 0) | (col >= n)
        if bad.any():
            raise ParameterError(f"{where}: {name} = {col[bad][0]:g} is not an index of the lidar's {n} "
                                 f"{name}s (0 .. {n - 1})")  # fmt: skip
    if not np.isfinite(t).all():
        raise ParameterError(f"{where}: every row needs its time_s")
    beam, gate = beam.astype(int), gate.astype(int)
    counts = np.bincount(beam * n_gates + gate, minlength=n_beams * n_gates)
    if counts.min() != counts.max():
        raise ParameterError(f"{where}: every beam and gate needs the same number of scans (found {counts.min()} to "
                             f"{counts.max()} rows)")  # fmt: skip
    n_scan = int(counts[0])
    v_los = np.empty((n_scan, n_beams, n_gates))
    times = np.empty((n_scan, n_beams))
    for b in range(n_beams):
        for g in range(n_gates):
            sel = np.flatnonzero((beam == b) & (gate == g))
            sel = sel[np.argsort(t[sel], kind="stable")]
            if g == 0:
                times[:, b] = t[sel]
            elif not np.array_equal(t[sel], times[:, b]):
                raise ParameterError(f"{where}: the gates of beam {b} are not measured at the same times (a pulse "
                                     "measures all gates at once)")  # fmt: skip
            v_los[:, b, g] = v[sel]
        if np.any(np.diff(times[:, b]) <= 0):
            raise ParameterError(f"{where}: beam {b} has two scans at the same time")
    return v_los, times


def read_los_csv(path) -> LidarData:
    """The line-of-sight record of a CSV file as :class:`LidarData`; ParameterError for a missing or unknown key, a
    malformed column or value, a beam or gate not the lidar's, gates of a beam not measured together, or incomplete
    scans."""
    path = Path(path).expanduser()
    where = f"line-of-sight file {path}"
    header, table = parse_table(read_input_text(path, LINE_OF_SIGHT).splitlines(), where)
    return los_record(path, header, table, where)


def los_record(path: Path, header: dict, table: np.ndarray, where: str) -> LidarData:
    """The record of a line-of-sight table (n, 4) of COLUMNS with its HEADER_KEYS (strings), read from ``path``
    (lidar and mean-history files relative to it): every check of :func:`read_los_csv` after the parsing."""
    for key in ("lidar", "U_m_s"):
        if key not in header:
            raise ParameterError(f"{where}: the header must give `# {key} = ...` (see docs/constrained-fields.md)")
    key = header["lidar"]
    lidar = load_lidar(key if Path(key).suffix.lower() not in (".toml", ".json") else path.parent / key)
    try:
        U = float(header["U_m_s"])
    except ValueError:
        raise ParameterError(f"{where}: U_m_s = {header['U_m_s']!r} is not a number") from None
    if not (math.isfinite(U) and U > 0):
        raise ParameterError(f"{where}: U_m_s = {U:g} must be > 0")
    total = header.get("total_wind", "false").lower()
    if total not in ("true", "false"):
        raise ParameterError(f"{where}: total_wind = {header['total_wind']!r} must be true or false")
    spec = {k: header[k] for k in ("profile", "mean_history") if k in header} or None
    wind = mean_wind_spec(spec, total == "true", where, path.parent)
    v_los, times = _grid(table, len(lidar.azimuth_deg), len(lidar.ranges_m), where)
    return LidarData(v_los, times, lidar_attrs(lidar), wind is not None, 0.2, U, str(path),
                     None if wind is None else wind.to_attrs())  # fmt: skip
