"""The sweep manifest: DIR/manifest.json and DIR/manifest.csv, one record per planned run (fields: docs/sweep.md and
state.base_record; status "pending" | "complete" | "failed", action "ran" | "skipped" | "none")."""

from __future__ import annotations

import csv
import hashlib
import io
import json
from datetime import datetime, timezone
from pathlib import Path

from turbgen.atomic import write_file
from turbgen.version import __version__
from turbgen.store import open_store

MANIFEST_JSON = "manifest.json"
MANIFEST_CSV = "manifest.csv"
CSV_COLUMNS = ("name", "model", "preset", "U_m_s", "seed", "status", "action", "duration_s", "path", "checksum",
               "sigma_u_m_s", "sigma_v_m_s", "sigma_w_m_s", "validation", "lidar_k05_rad_m", "lidar_cutoff_hz", "lidar",
               "error", "finished_utc", "parameters")


def utc_now() -> str:
    """Current UTC time, ISO 8601 to the second ("2026-01-31T12:00:00+00:00")."""
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def store_checksum(path: str | Path) -> str:
    """'sha256:<hex>' of the u, v, w float32 data in stored order: the same for the same field whatever the chunking,
    compression or metadata. StoreError for an incomplete, unreadable, corrupted or non-finite store."""
    fs = open_store(path)
    h = hashlib.sha256()
    for comp in ("u", "v", "w"):
        for ix in range(fs.grid.nx):
            h.update(fs.read_plane(comp, ix).astype("<f4", copy=False).tobytes(order="C"))
    return "sha256:" + h.hexdigest()


def _validation_text(v) -> str:
    if v is None:
        return ""
    if isinstance(v, dict) and "passed" in v:
        return "pass" if v["passed"] else "fail"
    return json.dumps(v, sort_keys=True)


def _csv_text(records: list[dict]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for r in records:
        sig = r.get("sigma_m_s") or [None, None, None]
        row = {k: r.get(k) for k in CSV_COLUMNS}
        simulated = (r.get("lidar") or {}).get("simulated") or {}
        row.update(sigma_u_m_s=sig[0], sigma_v_m_s=sig[1], sigma_w_m_s=sig[2],
                   validation=_validation_text(r.get("validation")), lidar=_validation_text(r.get("lidar")),
                   lidar_k05_rad_m=simulated.get("k05_rad_m"), lidar_cutoff_hz=simulated.get("cutoff_hz"),
                   parameters=json.dumps(r.get("parameters"), sort_keys=True))  # fmt: skip
        writer.writerow({k: ("" if v is None else v) for k, v in row.items()})
    return buf.getvalue()


def write_manifest(directory: str | Path, sweep: dict, records: list[dict]) -> None:
    """Write manifest.json, then manifest.csv, of ``records`` (each file whole or not at all)."""
    d = Path(directory)
    counts = {s: sum(r["status"] == s for r in records) for s in ("complete", "failed", "pending")}
    doc = {"turbgen_version": __version__, "updated_utc": utc_now(), "sweep": sweep, "counts": counts, "runs": records}
    write_file(d / MANIFEST_JSON, json.dumps(doc, indent=1, sort_keys=False) + "\n")
    write_file(d / MANIFEST_CSV, _csv_text(records))


def read_manifest(directory: str | Path) -> dict | None:
    """The previous manifest.json of DIR (with a ``runs`` list), or None when there is none or it is unreadable."""
    try:
        doc = json.loads((Path(directory) / MANIFEST_JSON).read_text())
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) and isinstance(doc.get("runs"), list) else None
