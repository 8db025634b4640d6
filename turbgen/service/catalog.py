"""The service's catalog under --root: one directory per run id, nothing named by the client.

    ROOT/runs/<id>/request.json   model + canonical run mapping (written atomically before queueing)
    ROOT/runs/<id>/store.zarr     the field (published atomically by runs/; complete or absent)
    ROOT/runs/<id>/failed.json    the one-line reason of a failed run
    ROOT/runs/<id>/exports/<fmt>  cached exports;  ROOT/runs/<id>/validation/  report.json + PNG plots

A run id is the first 24 hex digits of the SHA-256 of the canonical JSON of (model, run parameters,
grid, turbgen version); the seed is one of the parameters. Identical requests give the same id.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
from pathlib import Path

from turbgen import __version__
from turbgen.errors import ParameterError, TurbgenError
from turbgen.spec.config import check_mapping
from turbgen.store.layout import grid_to_attrs
from turbgen.store.temporaries import temp_prefix

STORE = "store.zarr"
_ID = re.compile(r"^[0-9a-f]{24}$")


def build_run(body) -> tuple[str, object]:
    """(model, MannRun | KaimalRun) from a request body: {"model": ..., "preset": ..., <run config keys>}.

    The run config keys are those of ``turbgen mann|kaimal --config`` (schemas/<model>-run.schema.json);
    ``preset`` sets the stability keys as ``--preset`` does (at the body's U), given keys override it.
    ParameterError naming the bad field otherwise.
    """
    if not isinstance(body, dict):
        raise ParameterError("request body: expected a JSON object with the run config")
    body = dict(body)
    model = body.pop("model", "mann")
    entry = _model(model)
    preset = body.pop("preset", None)
    check_mapping(body, f"{model}-run", "run config")
    if preset is not None:
        from turbgen.spec.presets import run_keys

        if not isinstance(preset, str):
            raise ParameterError("preset: expected a preset name (string)")
        U = body.get("U_m_s")
        if isinstance(U, bool) or not isinstance(U, (int, float)):  # a bad U is reported by from_mapping below
            U = entry.spec.from_mapping({}).U_m_s
        body = {**run_keys(model, preset, U), **body}
    return model, entry.spec.from_mapping(body)


def _model(name):
    """The registry entry of ``name`` (ParameterError naming the field otherwise)."""
    from turbgen.runs.models import MODELS

    if name not in MODELS:
        raise ParameterError(f"model: {name!r} is not one of {', '.join(MODELS)}")
    return MODELS[name]


def canonical_mapping(run) -> dict:
    """The run mapping that rebuilds ``run`` exactly: its parameters (seed included) and its grid."""
    return {**run.parameters(), "grid": grid_to_attrs(run.grid)}


def run_from_canonical(model: str, mapping: dict):
    """Inverse of :func:`canonical_mapping` (used to re-queue runs after a restart)."""
    return _model(model).spec.from_mapping(mapping)


def run_id(model: str, mapping: dict) -> str:
    """24 hex digits of SHA-256 over the canonical JSON of model, mapping and turbgen version."""
    text = json.dumps({"model": model, "run": mapping, "turbgen": __version__}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def valid_id(text: str) -> bool:
    """True for a well-formed run id (anything else is answered 404 before touching the disk)."""
    return bool(_ID.match(text))


def write_json_atomic(path: Path, data) -> None:
    """Write JSON under a temporary name in the same directory and rename it into place."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.tmp-")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


class Catalog:
    """The run directories under ``root``/runs."""

    def __init__(self, root: Path):
        self.root = Path(root).absolute()
        self.runs = self.root / "runs"
        self.runs.mkdir(parents=True, exist_ok=True)
        self._complete: set[str] = set()  # ids whose store opened as complete (a published store stays so)

    def run_dir(self, rid: str) -> Path:
        if not valid_id(rid):
            raise KeyError(rid)
        return self.runs / rid

    def store_path(self, rid: str) -> Path:
        return self.run_dir(rid) / STORE

    def exists(self, rid: str) -> bool:
        return valid_id(rid) and (self.run_dir(rid) / "request.json").is_file()

    def request(self, rid: str) -> dict:
        return json.loads((self.run_dir(rid) / "request.json").read_text())

    def record(self, rid: str, model: str, mapping: dict, preset: str | None = None) -> None:
        """Create the run directory with its request (atomic), clearing an earlier failure.

        ``preset`` is a label for listing only (the run mapping already holds what it set)."""
        d = self.run_dir(rid)
        d.mkdir(exist_ok=True)
        (d / "failed.json").unlink(missing_ok=True)
        if not (d / "request.json").is_file():
            write_json_atomic(d / "request.json", {"model": model, "run": mapping, "preset": preset, "turbgen": __version__})

    def is_complete(self, rid: str) -> bool:
        """True when the store is published and opens as a complete turbgen store (remembered once true)."""
        if rid in self._complete:
            return True
        path = self.store_path(rid)
        if not path.is_dir():
            return False
        from turbgen.store import open_store

        try:
            open_store(path)
        except TurbgenError:
            return False
        self._complete.add(rid)
        return True

    def failure(self, rid: str) -> str | None:
        f = self.run_dir(rid) / "failed.json"
        try:
            return json.loads(f.read_text())["error"]
        except (OSError, ValueError, KeyError):
            return None

    def mark_failed(self, rid: str, reason: str) -> None:
        write_json_atomic(self.run_dir(rid) / "failed.json", {"error": reason})

    def clear_partial(self, rid: str) -> None:
        """Remove temporaries a killed run left (the writer's temp siblings of the store)."""
        d = self.run_dir(rid)
        prefix = temp_prefix(d / STORE)
        for p in d.iterdir():
            if p.name.startswith(prefix):
                shutil.rmtree(p, ignore_errors=True) if p.is_dir() else p.unlink(missing_ok=True)

    def ids(self) -> list[str]:
        return sorted(p.name for p in self.runs.iterdir() if valid_id(p.name) and (p / "request.json").is_file())

    def delete(self, rid: str) -> None:
        """Remove a run directory: renamed away first so no reader sees half of it."""
        d = self.run_dir(rid)
        self._complete.discard(rid)
        trash = self.runs / f".deleted-{rid}-{os.getpid()}"
        os.replace(d, trash)
        shutil.rmtree(trash, ignore_errors=True)

    def progress(self, rid: str, n_chunks_total: int) -> int:
        """Chunks already written to the temporary store of a running run (0 if none yet)."""
        d = self.run_dir(rid)
        prefix = temp_prefix(d / STORE)
        n = 0
        for p in d.iterdir() if d.is_dir() else ():
            if p.name.startswith(prefix) and p.is_dir():
                for comp in ("u", "v", "w"):
                    c = p / comp / "c"
                    if c.is_dir():
                        n += sum(len(files) for _, _, files in os.walk(c))
        return min(n, n_chunks_total)
