"""Writing a field store safely: temporary sibling directory, completeness marker last, atomic rename.

    with create_store(path, grid, attrs, chunk_t=None, overwrite=False) as w:
        w.write("u", ix, block, t0)        # block (nt_block, ny, nz), any thread

On normal exit of the ``with`` block the marker is written last, metadata consolidated and the
temporary directory renamed to ``path`` (atomic: same parent directory, same filesystem). On any
exception (KeyboardInterrupt included) the temporary directory is removed and ``path`` is untouched.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import secrets
import shutil
import signal
import threading
import warnings
from pathlib import Path

import numpy as np
import zarr

from turbgen import __version__
from turbgen.errors import StoreError, check_int
from turbgen.grid import Grid
from turbgen.store import layout

def temp_prefix(path: Path) -> str:
    """Name prefix of the temporary sibling directories used while writing ``path``."""
    return f".{path.name}.tmp-"


def _jsonable(value):
    """``value`` with numpy scalars/arrays and tuples turned into plain JSON types."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.floating):
        return float(str(value))  # shortest repr: float32(3.1) -> 3.1, not 3.0999999046325684
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def _looks_like_turbgen_store(path: Path) -> bool:
    try:
        meta = json.loads((path / "zarr.json").read_text())
    except (OSError, ValueError):
        return False
    attrs = meta.get("attributes", {}) if isinstance(meta, dict) else {}
    return isinstance(attrs, dict) and "turbgen_version" in attrs


def _check_caller_attrs(attrs: dict) -> dict:
    """Programming errors in the attributes a generator passes (not user input)."""
    missing = [k for k in layout.CALLER_ATTRS if k not in attrs]
    if missing:
        raise ValueError(f"store attrs lack {missing} (required: {list(layout.CALLER_ATTRS)})")
    reserved = [k for k in (*layout.WRITER_ATTRS, layout.MARKER) if k in attrs]
    if reserved:
        raise ValueError(f"store attrs {reserved} are set by the writer, do not pass them")
    out = _jsonable(dict(attrs))
    no_unit = [k for k in out["parameters"] if k not in out["units"]]
    if no_unit:
        raise ValueError(f"store attrs 'units' lack a unit for parameters {no_unit} ('1' dimensionless, '' text)")
    json.dumps(out, allow_nan=False)  # raises on values a JSON reader could not load
    return out


class StoreWriter:
    """Context manager writing one field store; use :func:`create_store` to make one.

    ``write`` may be called concurrently from several threads. Writes covering whole chunks
    (different planes/components, or time blocks aligned to ``chunk_t``) run in parallel;
    unaligned blocks of the same plane are serialised (zarr read-modify-writes partial chunks).
    Every (component, plane, time sample) must be written before the ``with`` block ends.
    """

    def __init__(self, path: Path, grid: Grid, attrs: dict, chunk_t: int, overwrite: bool):
        self.path = path
        self.grid = grid
        self.chunk_t = chunk_t
        self._attrs = attrs
        self._overwrite = overwrite
        self._tmp: Path | None = None
        self._old_sigterm = None
        self._arrays: dict[str, zarr.Array] = {}
        self._written = {c: np.zeros((grid.nx, grid.nt), dtype=bool) for c in layout.COMPONENTS}
        self._bookkeeping = threading.Lock()
        self._plane_locks = {(c, ix): threading.Lock() for c in layout.COMPONENTS for ix in range(grid.nx)}

    # -- context protocol -------------------------------------------------------------------
    def __enter__(self) -> "StoreWriter":
        self._install_sigterm_handler()
        self._tmp = self.path.parent / f"{temp_prefix(self.path)}{os.getpid()}-{secrets.token_hex(4)}"
        try:
            self._create(self._tmp)
        except BaseException:
            self._discard()
            self._restore_sigterm_handler()
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is not None:
                self._discard()
                return False
            try:
                self._finish()
            except BaseException:
                self._discard()
                raise
            return False
        finally:
            self._restore_sigterm_handler()

    def _install_sigterm_handler(self) -> None:
        """Turn SIGTERM (e.g. a batch scheduler's kill) into SystemExit so the temp dir is removed."""
        in_main = threading.current_thread() is threading.main_thread()
        if in_main and signal.getsignal(signal.SIGTERM) == signal.SIG_DFL:
            signal.signal(signal.SIGTERM, _exit_on_sigterm)
            self._old_sigterm = signal.SIG_DFL

    def _restore_sigterm_handler(self) -> None:
        if self._old_sigterm is not None:
            signal.signal(signal.SIGTERM, self._old_sigterm)
            self._old_sigterm = None

    # -- writing ----------------------------------------------------------------------------
    def add_attrs(self, **attrs) -> None:
        """Add attributes known only after generation (e.g. a synthesis report); written before the marker."""
        if self._tmp is None:
            raise RuntimeError("StoreWriter.add_attrs outside its 'with' block")
        clash = [k for k in attrs if k in self._group.attrs or k == layout.MARKER]
        if clash:
            raise ValueError(f"store attrs {clash} are already set")
        self._group.attrs.update(_jsonable(attrs))

    def write(self, component: str, ix: int, data: np.ndarray, t0: int = 0) -> None:
        """Write ``data`` (nt_block, ny, nz) to ``component`` at plane index ``ix``, time ``t0``."""
        if self._tmp is None:
            raise RuntimeError("StoreWriter.write outside its 'with' block")
        if component not in self._arrays:
            raise ValueError(f"component {component!r} is not one of {layout.COMPONENTS}")
        g = self.grid
        if not 0 <= ix < g.nx:
            raise ValueError(f"plane index {ix} outside [0, {g.nx - 1}]")
        block = np.asarray(data, dtype=np.float32)
        if block.ndim != 3 or block.shape[1:] != (g.ny, g.nz) or not 0 <= t0 <= g.nt - block.shape[0]:
            raise ValueError(
                f"block of shape {block.shape} at t0={t0} does not fit plane shape ({g.nt}, {g.ny}, {g.nz})"
            )
        if not np.isfinite(block.sum(dtype=np.float64)):
            raise ValueError(f"{component} plane {ix}: block at t0={t0} contains NaN or inf")
        t1 = t0 + block.shape[0]
        aligned = t0 % self.chunk_t == 0 and (t1 % self.chunk_t == 0 or t1 == g.nt)
        if aligned:
            self._arrays[component][t0:t1, ix] = block
        else:
            with self._plane_locks[(component, ix)]:
                self._arrays[component][t0:t1, ix] = block
        with self._bookkeeping:
            self._written[component][ix, t0:t1] = True

    # -- internals --------------------------------------------------------------------------
    def _create(self, root: Path) -> None:
        g = self.grid
        attrs = dict(self._attrs)
        attrs.update(
            turbgen_version=__version__,
            created_utc=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            layout_version=layout.LAYOUT_VERSION,
            frame=layout.FRAME,
            frame_note=layout.FRAME_NOTE,
            grid=layout.grid_to_attrs(g),
        )
        group = zarr.open_group(str(root), mode="w-", zarr_format=3, attributes=attrs)
        for name, values in layout.coordinates(g).items():
            arr = group.create_array(
                name,
                shape=values.shape,
                dtype=layout.COORD_DTYPE,
                chunks=values.shape,
                dimension_names=(name,),
                attributes=layout.COORD_ATTRS[name],
                compressors=None,
            )
            arr[:] = values
        for c in layout.COMPONENTS:
            self._arrays[c] = group.create_array(
                c,
                shape=g.shape,
                dtype=layout.DTYPE,
                chunks=layout.chunk_shape(g, self.chunk_t),
                dimension_names=layout.DIMS,
                attributes=layout.COMPONENT_ATTRS[c],
                compressors=layout.compressor(),
                fill_value=np.nan,
                config={"write_empty_chunks": True},
            )
        self._group = group

    def _finish(self) -> None:
        for c, done in self._written.items():
            if not done.all():
                ix, it = np.argwhere(~done)[0]
                raise RuntimeError(
                    f"store {self.path}: {c} at plane x = {self.grid.x_m[ix]:g} m was not written from "
                    f"t index {it} ({int((~done).sum())} samples of {c} missing); nothing was written"
                )
        self._group.attrs[layout.MARKER] = True  # the completeness marker, written last ...
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="Consolidated metadata", category=UserWarning)
            zarr.consolidate_metadata(str(self._tmp))  # ... together with the consolidated metadata
        self._install()

    def _install(self) -> None:
        """Rename the finished temporary directory to ``path`` (replacing an old store if allowed)."""
        old = None
        if self.path.exists() or self.path.is_symlink():
            if not self._overwrite:
                raise StoreError(f"{self.path} appeared while writing; not replaced (use --overwrite)")
            old = self.path.parent / f".{self.path.name}.old-{os.getpid()}-{secrets.token_hex(4)}"
            os.rename(self.path, old)
        try:
            os.rename(self._tmp, self.path)
        except BaseException:
            if old is not None:
                os.rename(old, self.path)
            raise
        self._tmp = None
        if old is not None:
            _remove(old)

    def _discard(self) -> None:
        if self._tmp is not None:
            _remove(self._tmp)
            self._tmp = None


def _exit_on_sigterm(signum, frame):
    raise SystemExit(128 + signum)


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    elif path.exists() or path.is_symlink():
        path.unlink()


def create_store(
    path, grid: Grid, attrs: dict, *, chunk_t: int | None = None, overwrite: bool = False
) -> StoreWriter:
    """A :class:`StoreWriter` for a new field store at ``path`` (use it as a context manager).

    ``attrs`` must hold model, parameters, units (a unit for every parameter), seed, U_m_s and
    hub_height_m; the writer adds turbgen_version, created_utc, layout_version, frame, frame_note,
    grid and finally the completeness marker. ``chunk_t`` is the time-chunk length (default
    min(nt, 1024)). Raises StoreError before anything is created when ``path`` exists and
    ``overwrite`` is False, or when ``path`` exists and is not a turbgen store (never replaced).
    """
    path = Path(path).expanduser().absolute()
    if chunk_t is None:
        chunk_t = layout.default_chunk_t(grid.nt)
    chunk_t = check_int("chunks (time samples per chunk)", chunk_t, 1, grid.nt)
    full = _check_caller_attrs(attrs)
    layout.validate_attrs(
        {
            **full,
            "turbgen_version": __version__,
            "created_utc": "2000-01-01T00:00:00+00:00",
            "layout_version": layout.LAYOUT_VERSION,
            "frame": layout.FRAME,
            "frame_note": layout.FRAME_NOTE,
            "grid": layout.grid_to_attrs(grid),
            layout.MARKER: True,
        },
        where="store attrs",
        error=ValueError,
    )
    if path.exists() or path.is_symlink():
        if not overwrite:
            raise StoreError(f"{path} already exists; use --overwrite to replace it")
        if not _looks_like_turbgen_store(path):
            raise StoreError(f"{path} exists and is not a turbgen store; refusing to replace it")
    if not path.parent.is_dir():
        raise StoreError(f"output directory {path.parent} does not exist")
    if not os.access(path.parent, os.W_OK):
        raise StoreError(f"output directory {path.parent} is not writable")
    return StoreWriter(path, grid, full, chunk_t, overwrite)
