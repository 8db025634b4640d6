"""Writing a field store safely through zarr's public API: temporary sibling directory, completeness marker
last, atomic rename (``temporaries.publish``).

    with create_store(path, grid, attrs, chunk_t=None, overwrite=False) as w:
        w.write("u", ix, block, t0)        # block (nt_block, ny, nz), any thread

On any exception the temporary directory is removed and ``path`` is untouched; a disk error is a one-line StoreError."""

from __future__ import annotations

import datetime as _dt
import math
import os
import threading
from pathlib import Path

import numpy as np
import zarr

from turbgen import fft
from turbgen.version import __version__
from turbgen.errors import StoreError, check_int
from turbgen.grid import Grid
from turbgen.resources import format_bytes, require_disk
from turbgen.store import layout
from turbgen.store.attributes import check_caller_attrs, jsonable, looks_like_turbgen_store
from turbgen.store.chunk_files import write_chunk
from turbgen.store.discard import finish_before_raising, remove_path
from turbgen.cancellation import raise_if_stop_requested
from turbgen.store.temporaries import publish, remove_dead_temporaries, report_removed, temp_name
from turbgen.store.paths import check_output_path


class StoreWriter:
    """Context manager writing one field store (made by :func:`create_store`); ``write`` is thread-safe (unaligned
    blocks of one plane one at a time: zarr read-modify-writes a partial chunk). Every sample must be written before the
    ``with`` block ends, else RuntimeError and nothing is published."""

    def __init__(self, path: Path, grid: Grid, attrs: dict, chunk_t: int, overwrite: bool):
        self.path = path
        self.grid = grid
        self.chunk_t = chunk_t
        self._attrs = attrs
        self._overwrite = overwrite
        self._tmp: Path | None = None
        self._arrays: dict[str, zarr.Array] = {}
        self._written = {c: np.zeros((grid.nx, grid.nt), dtype=bool) for c in layout.COMPONENTS}
        self._bookkeeping = threading.Lock()
        self._squares: dict[tuple, float] = {}  # (component, ix, t0, t1) -> the block's float64 sum of squares
        self._plane_locks = {(c, ix): threading.Lock() for c in layout.COMPONENTS for ix in range(grid.nx)}

    def __enter__(self) -> "StoreWriter":
        self._tmp = temp_name(self.path)
        try:
            finish_before_raising(self._create, self._tmp)
        except BaseException as exc:
            self._abandon(exc)
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is not None:
            self._abandon(exc)
            return False
        try:
            raise_if_stop_requested()  # an interruption whose exception was swallowed on the way publishes nothing
            self._finish()
        except BaseException as err:
            self._abandon(err)
            raise
        return False

    def add_attrs(self, **attrs) -> None:
        """Add attributes known only after generation (e.g. a synthesis report), written before the marker; numpy
        values and tuples are stored as plain JSON types. ValueError for one already set or the marker itself."""
        if self._tmp is None:
            raise RuntimeError("StoreWriter.add_attrs outside its 'with' block")
        clash = [k for k in attrs if k in self._group.attrs or k == layout.MARKER]
        if clash:
            raise ValueError(f"store attrs {clash} are already set")
        finish_before_raising(self._group.attrs.update, jsonable(attrs))

    def write(self, component: str, ix: int, data: np.ndarray, t0: int = 0, squares: bool = False):
        """Write ``data`` (nt_block, ny, nz) [m/s] as float32 to ``component`` at plane index ``ix``, time ``t0``;
        returns the block's float64 sum [m/s], with ``squares`` also its sum of squares [m^2/s^2]. ValueError as
        :func:`checked_block`."""
        if self._tmp is None:
            raise RuntimeError("StoreWriter.write outside its 'with' block")
        g = self.grid
        block, total, sum_sq = checked_block(g, component, ix, data, t0)
        t1 = t0 + block.shape[0]
        aligned = t0 % self.chunk_t == 0 and (t1 % self.chunk_t == 0 or t1 == g.nt)
        if aligned:  # chunk by chunk: whole chunks by the raw fast path where it applies (chunk_files), else through
            # zarr, which stores a value shaped like its chunk as is (the last, shorter chunk padded with the fill value)
            array = self._arrays[component]
            for a in range(t0, t1, self.chunk_t):
                b = min(a + self.chunk_t, t1)
                part = block[a - t0 : b - t0]
                if b - a < self.chunk_t or not write_chunk(array, (a // self.chunk_t, ix, 0, 0), part):
                    finish_before_raising(array.__setitem__, (slice(a, b), slice(ix, ix + 1)), part[:, None])
        else:
            with self._plane_locks[(component, ix)]:
                finish_before_raising(self._arrays[component].__setitem__, (slice(t0, t1), ix), block)
        with self._bookkeeping:
            self._written[component][ix, t0:t1] = True
            self._squares[(component, ix, t0, t1)] = sum_sq
        return (total, sum_sq) if squares else total

    def _create(self, root: Path) -> None:
        g = self.grid
        group = zarr.open_group(str(root), mode="w-", zarr_format=3, attributes=with_writer_attrs(self._attrs, g))
        for name, values in layout.coordinates(g).items():
            arr = group.create_array(name, shape=values.shape, dtype=layout.COORD_DTYPE, chunks=values.shape,
                                     dimension_names=(name,), attributes=layout.COORD_ATTRS[name], compressors=None)
            arr[:] = values
        for c in layout.COMPONENTS:
            self._arrays[c] = group.create_array(
                c, shape=g.shape, dtype=layout.DTYPE, chunks=layout.chunk_shape(g, self.chunk_t),
                dimension_names=layout.DIMS, attributes=layout.COMPONENT_ATTRS[c], compressors=layout.compressor(),
                fill_value=np.nan, config={"write_empty_chunks": True})
        self._group = group

    def _finish(self) -> None:
        for c, done in self._written.items():
            if not done.all():
                ix, it = np.argwhere(~done)[0]
                raise RuntimeError(f"store {self.path}: {c} at plane x = {self.grid.x_m[ix]:g} m was not written from "
                                   f"t index {it} ({int((~done).sum())} samples of {c} missing); nothing was written")
        finish_before_raising(self._mark_complete)
        self._install()

    def _mark_complete(self) -> None:
        self._group.attrs[layout.RMS_ATTR] = rms_from_squares(self._squares, self.grid)
        self._group.attrs[layout.MARKER] = True  # the completeness marker, written last ...
        layout.silence_consolidated_metadata_warning()
        zarr.consolidate_metadata(str(self._tmp))  # ... together with the consolidated metadata

    def _install(self) -> None:
        """Rename the finished temporary directory to ``path`` (swapping out an old store if allowed)."""
        if (self.path.exists() or self.path.is_symlink()) and self._overwrite and not looks_like_turbgen_store(self.path):
            raise StoreError(f"{self.path} appeared while writing and is not a turbgen store; not replaced")
        try:
            old = publish(self._tmp, self.path, replace=self._overwrite)
        except FileExistsError:
            raise StoreError(f"{self.path} appeared while writing; not replaced (use `overwrite`)") from None
        self._tmp = old  # the swapped-out old store (a dead writer's garbage should we die now), or None
        self._discard()

    def _discard(self) -> None:
        if self._tmp is not None:
            remove_path(self._tmp)
            self._tmp = None

    def _abandon(self, exc: BaseException) -> None:
        """Discard the temporary directory; re-raise an OSError of the file system (disk full, read-only, ...) as a
        one-line StoreError."""
        self._discard()
        if isinstance(exc, OSError) and not isinstance(exc, StoreError):
            reason = exc.strerror or (str(exc).splitlines() or [type(exc).__name__])[0]
            raise StoreError(f"writing {self.path} failed: {reason} (errno {exc.errno}); nothing was written") from None


def with_writer_attrs(attrs: dict, grid: Grid) -> dict:
    """The caller's checked ``attrs`` plus what the writer adds: turbgen_version, created_utc (now, ISO 8601),
    layout_version, fft_backend (turbgen.fft.current), frame, frame_note, grid."""
    return {**attrs, "turbgen_version": __version__,
            "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "layout_version": layout.LAYOUT_VERSION, layout.FFT_ATTR: fft.current(), "frame": layout.FRAME, "frame_note": layout.FRAME_NOTE,
            "grid": layout.grid_to_attrs(grid)}  # fmt: skip


def validated_caller_attrs(attrs: dict, grid: Grid) -> dict:
    """The caller's ``attrs`` checked (check_caller_attrs) and, with the writer's, against the schema (ValueError)."""
    full = check_caller_attrs(attrs)
    layout.validate_attrs({**with_writer_attrs(full, grid), layout.MARKER: True}, where="store attrs", error=ValueError)
    return full


def rms_from_squares(squares: dict, grid: Grid) -> dict[str, float]:
    """Component -> rms [m/s] from the blocks' sums of squares, summed in sorted key order (thread-independent)."""
    n = grid.nx * grid.nt * grid.ny * grid.nz
    total = {c: 0.0 for c in layout.COMPONENTS}
    for key in sorted(squares):
        total[key[0]] += squares[key]
    return {c: math.sqrt(total[c] / n) for c in layout.COMPONENTS}


def checked_block(grid: Grid, component: str, ix: int, data, t0: int) -> tuple[np.ndarray, float, float]:
    """``data`` as the float32 block stored at (``component``, ``ix``, ``t0``), with its float64 sum and sum of squares;
    ValueError for an unknown component, a plane out of range, a block that does not fit, or NaN or inf."""
    if component not in layout.COMPONENTS:
        raise ValueError(f"component {component!r} is not one of {layout.COMPONENTS}")
    if not 0 <= ix < grid.nx:
        raise ValueError(f"plane index {ix} outside [0, {grid.nx - 1}]")
    block = np.asarray(data, dtype=np.float32)
    if block.ndim != 3 or block.shape[1:] != (grid.ny, grid.nz) or not 0 <= t0 <= grid.nt - block.shape[0]:
        raise ValueError(f"block of shape {block.shape} at t0={t0} does not fit plane shape ({grid.nt}, {grid.ny}, "
                         f"{grid.nz})")
    from turbgen.store.block_sums import block_sums  # numba: only for commands that write fields

    total, sum_sq = block_sums(block)
    if not np.isfinite(total):
        raise ValueError(f"{component} plane {ix}: block at t0={t0} contains NaN or inf")
    return block, total, sum_sq


def check_new_store(path, grid: Grid, *, chunk_t: int | None = None, overwrite: bool = False,
                    scratch_bytes: int = 0) -> tuple[Path, int]:
    """What :func:`create_store` checks before it creates anything; returns (absolute path, chunk_t).

    Dead writers' temporaries of ``path`` are removed first. ``chunk_t`` in [1, nt] (default min(nt, 1024));
    ``scratch_bytes``: scratch files the disk check counts. ParameterError for a bad path, chunk_t or too little disk;
    StoreError for an existing ``path`` without ``overwrite`` or not a turbgen store, or an unwritable directory."""
    path = check_output_path(path).absolute()
    chunk_t = layout.default_chunk_t(grid.nt) if chunk_t is None else chunk_t
    chunk_t = check_int("chunks (time samples per chunk)", chunk_t, 1, grid.nt)
    if path.exists() or path.is_symlink():
        if not looks_like_turbgen_store(path):  # never replaced, so `overwrite` is no remedy: not suggested
            kind = "a directory" if path.is_dir() else "a file"
            raise StoreError(f"{path} is {kind}, not a turbgen store; it will not be replaced (choose another `out`)")
        if not overwrite:
            raise StoreError(f"{path} already exists; use `overwrite` to replace it")
    if not path.parent.is_dir():
        raise StoreError(f"output directory {path.parent} does not exist")
    if not os.access(path.parent, os.W_OK):
        raise StoreError(f"output directory {path.parent} is not writable")
    report_removed(remove_dead_temporaries(path.parent, [path.name]))
    need = 3 * grid.nbytes_per_component()
    what = (f"the store ({' x '.join(map(str, grid.shape))}, 3 components, {format_bytes(need)} uncompressed)"
            + (f" and {format_bytes(scratch_bytes)} of scratch" if scratch_bytes else ""))
    require_disk(path.parent, need + scratch_bytes, what,
                 "free space there, choose another `out` or lower `nt`/`ny`/`nz`/`planes`")
    return path, chunk_t


def create_store(path, grid: Grid, attrs: dict, *, chunk_t: int | None = None, overwrite: bool = False) -> StoreWriter:
    """A :class:`StoreWriter` for a new field store at ``path`` (nothing is created before ``with``); ``attrs``: model,
    parameters, units, seed, U_m_s [m/s], hub_height_m [m] (the writer adds the rest). Refusals as
    :func:`check_new_store`; ValueError for ``attrs`` :func:`validated_caller_attrs` refuses."""
    full = validated_caller_attrs(attrs, grid)
    path, chunk_t = check_new_store(path, grid, chunk_t=chunk_t, overwrite=overwrite)
    return StoreWriter(path, grid, full, chunk_t, overwrite)
