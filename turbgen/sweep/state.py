"""What a sweep finds on disk: the state of each planned store and the manifest record of each run."""

from __future__ import annotations

import json
from pathlib import Path

from turbgen.errors import ParameterError, StoreError
from turbgen.runs.models import MODELS
from turbgen.store import open_store
from turbgen.store.layout import grid_to_attrs
from turbgen.store.temporaries import remove_dead_temporaries
from turbgen.sweep.manifest import MANIFEST_CSV, MANIFEST_JSON
from turbgen.sweep.plan import PlannedRun


def _norm(value):
    """JSON round trip: tuples -> lists, so attributes read back compare equal to planned ones."""
    return json.loads(json.dumps(value, default=lambda o: o.item() if hasattr(o, "item") else list(o)))


def _identity(model, attrs: dict, grid: dict) -> dict:
    keys = ("parameters", "seed", "U_m_s", "hub_height_m")
    return _norm({"model": model, **{k: attrs.get(k) for k in keys}, "grid": grid})


def store_state(path: Path, pr: PlannedRun) -> tuple[str, str | None]:
    """('absent' | 'incomplete' | 'mismatch' | 'complete', detail) of the store at ``path`` of ``pr``: a one-line
    store error or the keys differing from the plan (None when absent or complete)."""
    if not path.exists():
        return "absent", None
    try:
        fs = open_store(path)
    except StoreError as exc:
        return "incomplete", str(exc)
    planned_grid = grid_to_attrs(pr.run.grid)
    attrs = fs.attrs
    if attrs.get("model") in MODELS:  # read through the spec: stores of older layouts compare equal
        try:
            attrs = MODELS[attrs["model"]].spec.from_attrs(attrs).to_attrs()
        except ParameterError:
            pass  # compared as stored, so the difference is named
    stored = _identity(fs.attrs.get("model"), attrs, fs.attrs.get("grid"))
    planned = _identity(pr.model, pr.run.to_attrs(), planned_grid)
    if stored != planned:
        diff = sorted(k for k in planned if planned[k] != stored.get(k))
        return "mismatch", f"{path.name} exists with different {', '.join(diff)}; not overwritten"
    return "complete", None


def remove_dead_temps(directory: Path, names) -> list[Path]:
    """Remove the temporaries of stores ``names`` and of the manifests whose writer is dead; return them."""
    return remove_dead_temporaries(directory, [*names, MANIFEST_JSON, MANIFEST_CSV])


def base_record(pr: PlannedRun) -> dict:
    """The manifest record of a planned run before it is inspected: status "pending", action "none", no results."""
    empty = dict.fromkeys(("duration_s", "checksum", "sigma_m_s", "validation", "lidar", "error", "finished_utc"))
    return {"name": pr.name, "model": pr.model, "preset": pr.preset, "U_m_s": pr.U_m_s, "seed": pr.seed,
            "path": pr.store_name, "status": "pending", "action": "none", **empty,
            "parameters": _norm(pr.run.to_attrs()["parameters"])}
