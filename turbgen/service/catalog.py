"""The service's catalog under --root: one directory per run id, nothing named by the client.

    ROOT/runs/<id>/request.json   model + canonical run mapping (written atomically before queueing)
    ROOT/runs/<id>/store.zarr     the field (published atomically by runs/; complete or absent)
    ROOT/runs/<id>/failed.json    the one-line reason of a failed run
    ROOT/runs/<id>/starts.json    how many times the run was started (failed after jobs.MAX_STARTS)
    ROOT/runs/<id>/.failure-room  4 KiB kept until failed.json is written, so a full disk can still record it
    ROOT/runs/<id>/exports/<fmt>  cached exports;  ROOT/runs/<id>/validation/  report.json + PNG plots
    ROOT/work/                    derived products being computed (temporary names, turbgen.service.derived)
    ROOT/stencils/                the Mann stencil cache of the runs (size-capped, turbgen.service.cleanup)

Run ids: turbgen.service.run_ids."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
from pathlib import Path

from turbgen.atomic import write_file
from turbgen.version import __version__
from turbgen.errors import TurbgenError
from turbgen.service.run_ids import valid_id
from turbgen.service.uploads import ConstraintUploads
from turbgen.store.discard import remove_path
from turbgen.store.reader import chunks_written
from turbgen.store.temporaries import temp_name, temp_prefix

STORE = "store.zarr"
STARTS = "starts.json"
FAILURE_ROOM, FAILURE_ROOM_BYTES = ".failure-room", 4096


def write_json_atomic(path: Path, data) -> None:
    """Write the JSON-able ``data`` to ``path`` whole or not at all (:func:`turbgen.atomic.write_file`)."""
    write_file(path, json.dumps(data, indent=1))


class Catalog:
    """The run directories under the server's --root ``root``/runs (created if missing); methods taking a run
    id ``rid`` raise KeyError if it is not a well-formed id."""

    def __init__(self, root: Path):
        self.root = Path(root).absolute()
        self.runs = self.root / "runs"
        self.runs.mkdir(parents=True, exist_ok=True)
        self.work = self.root / "work"
        self.work.mkdir(exist_ok=True)
        self.uploads = ConstraintUploads(self.root)  # measurements uploaded for constrained runs
        self._complete: set[str] = set()  # ids whose store opened as complete (a published store stays so)

    def run_dir(self, rid: str) -> Path:
        if not valid_id(rid):
            raise KeyError(rid)
        return self.runs / rid

    def store_path(self, rid: str) -> Path:
        return self.run_dir(rid) / STORE

    def exists(self, rid: str) -> bool:
        """True when ``rid`` is a well-formed id with a recorded request."""
        return valid_id(rid) and (self.run_dir(rid) / "request.json").is_file()

    def request(self, rid: str) -> dict:
        """The recorded request of run ``rid`` (model, run mapping, preset, turbgen version)."""
        return json.loads((self.run_dir(rid) / "request.json").read_text())

    def record(self, rid: str, model: str, mapping: dict, preset: str | None = None) -> None:
        """Create the run directory with its request (``model``, canonical run ``mapping``, ``preset`` label),
        atomically, clearing an earlier failure."""
        d = self.run_dir(rid)
        d.mkdir(exist_ok=True)
        (d / "failed.json").unlink(missing_ok=True)
        if not (d / "request.json").is_file():
            write_json_atomic(d / "request.json", {"model": model, "run": mapping, "preset": preset, "turbgen": __version__})
        with contextlib.suppress(OSError):  # room for failed.json, released when it is written (a full disk)
            (d / FAILURE_ROOM).write_bytes(bytes(FAILURE_ROOM_BYTES))

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
        """The recorded one-line reason of a failed run, or None."""
        f = self.run_dir(rid) / "failed.json"
        try:
            return json.loads(f.read_text())["error"]
        except (OSError, ValueError, KeyError):
            return None

    def mark_failed(self, rid: str, reason: str) -> None:
        """Record run ``rid`` as failed with the one-line ``reason`` (failed.json, atomic)."""
        d = self.run_dir(rid)
        (d / FAILURE_ROOM).unlink(missing_ok=True)  # on a full disk, the room kept for this record
        write_json_atomic(d / "failed.json", {"error": reason})

    def starts(self, rid: str) -> int:
        """How many times run ``rid`` was started (by this server or one before it); 0 if never or unknown."""
        try:
            return int(json.loads((self.run_dir(rid) / STARTS).read_text())["starts"])
        except (OSError, ValueError, KeyError, TypeError):
            return 0

    def count_start(self, rid: str) -> None:
        """Record one more start of run ``rid`` across restarts (best effort: a full disk fails the run anyway)."""
        with contextlib.suppress(OSError):
            write_json_atomic(self.run_dir(rid) / STARTS, {"starts": self.starts(rid) + 1})

    def temporaries(self, rid: str) -> list[Path]:
        """The writer's temporary siblings of run ``rid``'s store (a running run's, or a killed run's leftovers)."""
        d = self.run_dir(rid)
        prefix = temp_prefix(d / STORE)
        return [p for p in (d.iterdir() if d.is_dir() else ()) if p.name.startswith(prefix)]

    def clear_partial(self, rid: str) -> None:
        """Remove temporaries a killed run left."""
        for p in self.temporaries(rid):
            remove_path(p)

    def ids(self) -> list[str]:
        """Ids of every recorded run, sorted."""
        return sorted(p.name for p in self.runs.iterdir() if valid_id(p.name) and (p / "request.json").is_file())

    def delete(self, rid: str) -> None:
        """Remove a run directory, renamed away first so no reader sees half of it."""
        d = self.run_dir(rid)
        self._complete.discard(rid)
        trash = temp_name(d)  # a temporary name: start-up removes it if this process dies before rmtree finishes
        os.replace(d, trash)
        shutil.rmtree(trash, ignore_errors=True)

    def progress(self, rid: str, n_chunks_total: int) -> int:
        """Chunks already written to the temporary store of a running run, at most ``n_chunks_total`` (0 if none yet)."""
        return min(sum(chunks_written(p) for p in self.temporaries(rid)), n_chunks_total)
