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

    Parameters
    ----------
    body : dict
        The request's JSON object; ``model`` defaults to "mann".

    Returns
    -------
    tuple of (str, MannRun or KaimalRun)
        The model name and the run.

    Raises
    ------
    ParameterError
        Naming the bad field: not an object, unknown model or preset, schema violation or a value out of range.
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
    """The run mapping that rebuilds ``run`` exactly: its parameters (seed included) and its grid.

    Parameters
    ----------
    run : MannRun or KaimalRun
        The run.

    Returns
    -------
    dict
        ``run.parameters()`` plus ``grid`` (store attribute form).
    """
    return {**run.parameters(), "grid": grid_to_attrs(run.grid)}


def run_from_canonical(model: str, mapping: dict):
    """Inverse of :func:`canonical_mapping` (used to re-queue runs after a restart).

    Parameters
    ----------
    model : str
        Model name.
    mapping : dict
        A canonical mapping.

    Returns
    -------
    MannRun or KaimalRun

    Raises
    ------
    ParameterError
        For an unknown model, key or a value out of range.
    """
    return _model(model).spec.from_mapping(mapping)


def run_id(model: str, mapping: dict) -> str:
    """24 hex digits of SHA-256 over the canonical JSON of model, mapping and turbgen version.

    Parameters
    ----------
    model : str
        Model name.
    mapping : dict
        The canonical run mapping (:func:`canonical_mapping`).

    Returns
    -------
    str
    """
    text = json.dumps({"model": model, "run": mapping, "turbgen": __version__}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def valid_id(text: str) -> bool:
    """True for a well-formed run id (anything else is answered 404 before touching the disk).

    Parameters
    ----------
    text : str
        Candidate id.

    Returns
    -------
    bool
    """
    return bool(_ID.match(text))


def write_json_atomic(path: Path, data) -> None:
    """Write JSON under a temporary name in the same directory and rename it into place.

    Parameters
    ----------
    path : Path
        Target file; its directory must exist.
    data : object
        JSON-able value.

    Returns
    -------
    None

    Raises
    ------
    OSError
        If the file cannot be written (the temporary is removed).
    """
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.tmp-")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


class Catalog:
    """The run directories under ``root``/runs.

    Parameters
    ----------
    root : Path
        The server's --root (``root/runs`` is created if missing).
    """

    def __init__(self, root: Path):
        self.root = Path(root).absolute()
        self.runs = self.root / "runs"
        self.runs.mkdir(parents=True, exist_ok=True)
        self._complete: set[str] = set()  # ids whose store opened as complete (a published store stays so)

    def run_dir(self, rid: str) -> Path:
        """Directory of run ``rid``.

        Parameters
        ----------
        rid : str
            Run id.

        Returns
        -------
        Path

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        """
        if not valid_id(rid):
            raise KeyError(rid)
        return self.runs / rid

    def store_path(self, rid: str) -> Path:
        """Path of run ``rid``'s store.

        Parameters
        ----------
        rid : str
            Run id.

        Returns
        -------
        Path

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        """
        return self.run_dir(rid) / STORE

    def exists(self, rid: str) -> bool:
        """True when ``rid`` is a well-formed id with a recorded request.

        Parameters
        ----------
        rid : str
            Run id.

        Returns
        -------
        bool
        """
        return valid_id(rid) and (self.run_dir(rid) / "request.json").is_file()

    def request(self, rid: str) -> dict:
        """The recorded request of run ``rid`` (model, run mapping, preset, turbgen version).

        Parameters
        ----------
        rid : str
            Run id.

        Returns
        -------
        dict

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        OSError, ValueError
            If request.json is missing or not valid JSON.
        """
        return json.loads((self.run_dir(rid) / "request.json").read_text())

    def record(self, rid: str, model: str, mapping: dict, preset: str | None = None) -> None:
        """Create the run directory with its request (atomic), clearing an earlier failure.

        Parameters
        ----------
        rid : str
            Run id.
        model : str
            Model name.
        mapping : dict
            Canonical run mapping.
        preset : str, optional
            A label for listing only (the run mapping already holds what it set).

        Returns
        -------
        None

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        """
        d = self.run_dir(rid)
        d.mkdir(exist_ok=True)
        (d / "failed.json").unlink(missing_ok=True)
        if not (d / "request.json").is_file():
            write_json_atomic(d / "request.json", {"model": model, "run": mapping, "preset": preset, "turbgen": __version__})

    def is_complete(self, rid: str) -> bool:
        """True when the store is published and opens as a complete turbgen store (remembered once true).

        Parameters
        ----------
        rid : str
            Run id.

        Returns
        -------
        bool

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        """
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
        """The recorded one-line reason of a failed run, or None.

        Parameters
        ----------
        rid : str
            Run id.

        Returns
        -------
        str or None

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        """
        f = self.run_dir(rid) / "failed.json"
        try:
            return json.loads(f.read_text())["error"]
        except (OSError, ValueError, KeyError):
            return None

    def mark_failed(self, rid: str, reason: str) -> None:
        """Record run ``rid`` as failed with ``reason`` (failed.json, atomic).

        Parameters
        ----------
        rid : str
            Run id.
        reason : str
            One-line reason.

        Returns
        -------
        None

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        """
        write_json_atomic(self.run_dir(rid) / "failed.json", {"error": reason})

    def clear_partial(self, rid: str) -> None:
        """Remove temporaries a killed run left (the writer's temp siblings of the store).

        Parameters
        ----------
        rid : str
            Run id (its directory must exist).

        Returns
        -------
        None

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        """
        d = self.run_dir(rid)
        prefix = temp_prefix(d / STORE)
        for p in d.iterdir():
            if p.name.startswith(prefix):
                shutil.rmtree(p, ignore_errors=True) if p.is_dir() else p.unlink(missing_ok=True)

    def ids(self) -> list[str]:
        """Ids of every recorded run, sorted.

        Returns
        -------
        list of str
        """
        return sorted(p.name for p in self.runs.iterdir() if valid_id(p.name) and (p / "request.json").is_file())

    def delete(self, rid: str) -> None:
        """Remove a run directory: renamed away first so no reader sees half of it.

        Parameters
        ----------
        rid : str
            Run id.

        Returns
        -------
        None

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        OSError
            If the directory does not exist.
        """
        d = self.run_dir(rid)
        self._complete.discard(rid)
        trash = self.runs / f".deleted-{rid}-{os.getpid()}"
        os.replace(d, trash)
        shutil.rmtree(trash, ignore_errors=True)

    def progress(self, rid: str, n_chunks_total: int) -> int:
        """Chunks already written to the temporary store of a running run (0 if none yet).

        Parameters
        ----------
        rid : str
            Run id.
        n_chunks_total : int
            Chunks of the complete store (upper bound of the count).

        Returns
        -------
        int

        Raises
        ------
        KeyError
            If ``rid`` is not a well-formed id.
        """
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
