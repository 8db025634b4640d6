"""Measurements uploaded to `turbgen serve` (``POST /constraints``) for runs conditioned on them.

The server opens no path a client names: the client uploads the *content* of a point-series JSON or CSV or a
line-of-sight CSV file, checked as ``--constrain`` would and kept as ``ROOT/constraints/<id>.json|.csv`` (id: 24
hex digits of its SHA-256). Content that names further files is refused."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from turbgen.atomic import write_file
from turbgen.errors import ParameterError
from turbgen.service.limits import check_json_depth
from turbgen.service.run_ids import valid_id

SUFFIXES = {"application/json": ".json", "text/csv": ".csv"}  # the content types an upload may have
MAX_UPLOAD_BYTES = 16 * 2**20  # a 2048 s record of 4 beams x 10 gates at 1 Hz is ~3 MB of CSV


class ConstraintUploads:
    """The uploaded measurements of a server, ``root/constraints`` (``root``: the server's --root)."""

    def __init__(self, root: Path):
        self.dir = Path(root).absolute() / "constraints"
        self.dir.mkdir(parents=True, exist_ok=True)

    def path(self, cid: str) -> Path:
        """The file of upload ``cid``; KeyError if ``cid`` is not a well-formed id or was not uploaded."""
        if valid_id(cid):
            for suffix in SUFFIXES.values():
                p = self.dir / f"{cid}{suffix}"
                if p.is_file():
                    return p
        raise KeyError(cid)

    def paths(self, ids) -> list[Path]:
        """The files of the uploads ``ids`` (a run's ``constrain``); ParameterError naming an unknown one."""
        out = []
        for n, cid in enumerate(ids):
            try:
                out.append(self.path(cid))
            except KeyError:
                raise ParameterError(f"constrain[{n}] = {cid!r} is not the id of uploaded measurements (upload them "
                                     "with POST /constraints; the service reads no file named by a client)") from None
        return out

    def add(self, media: str, data: bytes) -> tuple[str, dict, bool]:
        """Check and keep an upload of content type ``media`` (a key of SUFFIXES): (id, :func:`describe`, is new)."""
        cid = hashlib.sha256(data).hexdigest()[:24]
        try:
            return cid, describe(self.path(cid)), False
        except KeyError:
            pass
        where = f"upload {cid}"
        info = _summary(_point_series(data, where) if media == "application/json" else _csv(data, where))
        final = self.dir / f"{cid}{SUFFIXES[media]}"
        write_file(final, data)  # the same content under the same name: replacing a concurrent upload is harmless
        return cid, info, True


def describe(path: Path) -> dict:
    """:func:`_summary` of a kept upload."""
    from turbgen.runs.constrain import load_constraint  # the reader --constrain uses, so the formats cannot drift

    return _summary(load_constraint(path))


def _summary(data) -> dict:
    """What an upload holds: ``kind``, ``series`` (sensor components or beam gates), ``values`` (not missing),
    ``duration_s`` [s]."""
    from turbgen.spec.constraints import PointSeries

    if isinstance(data, PointSeries):
        series = [v for s in data.sensors for v in s.series.values()]
        return {"kind": "point series", "series": len(series), "values": sum(int(np.isfinite(v).sum()) for v in series),
                "duration_s": float(data.time_s[-1] - data.time_s[0])}  # fmt: skip
    return {"kind": "line of sight", "series": int(data.v_los.shape[1] * data.v_los.shape[2]),
            "values": int(np.isfinite(data.v_los).sum()), "duration_s": float(np.ptp(data.time_s))}  # fmt: skip


def _point_series(data: bytes, where: str):
    """The PointSeries of a JSON upload, checked as a constraint file; refused when its mean wind names a file."""
    from turbgen.spec.constraints import point_series_from_mapping

    try:
        value = json.loads(data)
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise ParameterError(f"{where}: not valid JSON ({' '.join(str(exc).split())[:200]})") from None
    check_json_depth(value)
    wind = value.get("mean_wind") if isinstance(value, dict) else None
    if isinstance(wind, dict):
        _refuse_file_references(wind.get("profile"), "mean_history" in wind, where)
    return point_series_from_mapping(value, where)


def _csv(data: bytes, where: str):
    """The LidarData of a line-of-sight CSV upload, or the PointSeries of a point-series one (its header declares
    sensors); refused when its header names a file."""
    from turbgen.spec.constraints import point_series_from_mapping
    from turbgen.spec.point_csv import declares_sensors, point_csv_mapping
    from turbgen.virtual_lidar.description import PRESETS
    from turbgen.virtual_lidar.los_csv import los_record, parse_table

    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ParameterError(f"{where}: a CSV upload must be UTF-8 text") from None
    if declares_sensors(text.splitlines()):
        mapping = point_csv_mapping(text, where)
        wind = mapping.get("mean_wind", {})
        _refuse_file_references(wind.get("profile"), "mean_history" in wind, where)
        return point_series_from_mapping(mapping, where)
    header, table = parse_table(text.splitlines(), where)
    lidar = header.get("lidar")
    if lidar is not None and lidar not in PRESETS:
        raise ParameterError(f"{where}: lidar = {lidar!r} must be a preset ({', '.join(PRESETS)}): the service opens "
                             "no file named by a client")
    _refuse_file_references(header.get("profile"), "mean_history" in header, where)
    return los_record(Path(where), header, table, where)


def _refuse_file_references(profile, history: bool, where: str) -> None:
    if history:
        raise ParameterError(f"{where}: mean_history names a file, which the service does not open; give the "
                             "data as fluctuations or with a power/log profile")
    if isinstance(profile, str) and profile.partition(":")[0].strip().lower() == "table":
        raise ParameterError(f"{where}: profile = {profile!r} names a file, which the service does not open; "
                             "use power:ALPHA or log:z0=Z0")
