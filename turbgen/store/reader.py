"""Opening a field store through zarr's public API: :func:`open_store` refuses anything that is not a complete,
consistent turbgen store, and :meth:`FieldStore.read_span` checks the data as it reads them (corrupted chunks, NaN,
values beyond the recorded rms: ``plausibility``). Every refusal is a one-line StoreError."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import zarr
from zarr.buffer import default_buffer_prototype

from turbgen.errors import ParameterError, StoreError
from turbgen.grid import Grid
from turbgen.store import layout
from turbgen.store.checked_reads import read_checked
from turbgen.store.plausibility import amplitude_limits, check_amplitudes, check_attributes, spread_warnings
from turbgen.store.temporaries import parse_temp, pid_alive, temp_prefix


class FieldStore:
    """A complete, validated field store opened read-only (see :func:`open_store`)."""

    def __init__(self, path: Path, grid: Grid, attrs: dict, group: zarr.Group):
        self.path = path
        self.grid = grid
        self.attrs = attrs
        self._group = group
        self._limits = amplitude_limits(attrs)

    def __repr__(self) -> str:
        return f"FieldStore({str(self.path)!r}, model={self.model!r}, shape={self.grid.shape})"

    @property
    def label(self) -> str:
        """How messages and reports name the field: the store's path."""
        return str(self.path)

    @property
    def model(self) -> str:
        """The turbulence model of the field ("mann", "kaimal", ...)."""
        return self.attrs["model"]

    @property
    def U_m_s(self) -> float:
        """Mean wind speed [m/s]."""
        return float(self.attrs["U_m_s"])

    @property
    def hub_height_m(self) -> float:
        """Hub height above ground [m]."""
        return float(self.attrs["hub_height_m"])

    @property
    def seed(self) -> int:
        """Random seed of the field."""
        return int(self.attrs["seed"])

    @property
    def chunk_t(self) -> int:
        """Time samples per chunk of the u, v, w arrays."""
        return int(self.array("u").chunks[0])

    def array(self, component: str) -> zarr.Array:
        """The zarr array (nt, nx, ny, nz) of float32 fluctuations [m/s] of ``component`` ("u", "v" or "w"), read-only;
        reading it directly does not check the data (:meth:`read_span` does). ParameterError for another component."""
        if component not in layout.COMPONENTS:
            raise ParameterError(f"component = {component!r} is not one of {', '.join(layout.COMPONENTS)}")
        return self._group[component]

    def dask(self, component: str):
        """``component`` as a lazy dask array (nt, nx, ny, nz) [m/s] with the stored chunks (data not checked)."""
        import dask.array as da

        arr = self.array(component)
        return da.from_zarr(arr, chunks=arr.chunks)

    def read_plane(self, component: str, ix: int) -> np.ndarray:
        """Plane ``ix`` of ``component`` over the whole time axis: :meth:`read_span` from 0 to nt; ParameterError
        for a plane index outside [0, nx - 1]."""
        if not 0 <= ix < self.grid.nx:
            raise ParameterError(f"plane index = {ix} is outside [0, {self.grid.nx - 1}]")
        return self.read_span(component, ix, 0, self.grid.nt)

    def read_span(self, component: str, ix: int, t0: int, t1: int, out: np.ndarray | None = None) -> np.ndarray:
        """Plane ``ix`` of ``component`` over t in [t0, t1), float32 (t1 - t0, ny, nz) [m/s], read and checked;
        StoreError for a chunk that does not decode, NaN/inf, or a value beyond AMPLITUDE_RMS times the recorded rms."""
        arr = self.array(component)
        block = read_checked(arr, ix, t0, t1, self.path, out=out)
        check_amplitudes(block, component, self._limits[component], self.path, ix, t0, arr.chunks[0])
        return block

    def check_chunks(self) -> None:
        """Read and check every chunk of u, v, w: StoreError at the first corrupted, non-finite or implausible one."""
        for c in layout.COMPONENTS:
            for ix in range(self.grid.nx):
                self.read_plane(c, ix)

    def nbytes_on_disk(self) -> int:
        """Total size of the files under the store directory [bytes]."""
        return sum(f.stat().st_size for f in self.path.rglob("*") if f.is_file())

    def summary(self) -> dict:
        """What ``turbgen info`` shows, as JSON-serialisable values (units in the key names); ``constraints`` (series,
        solver, residual [m/s]) only for a store conditioned on measurements."""
        g, a = self.grid, self.attrs
        return {
            "path": str(self.path),
            "complete": True,
            "model": self.model,
            "turbgen_version": a["turbgen_version"],
            "created_utc": a["created_utc"],
            "fft_backend": a.get(layout.FFT_ATTR),  # which round-off a re-run reproduces (None: an older store)
            "grid": layout.grid_to_attrs(g),
            "shape_t_x_y_z": list(g.shape),
            "duration_s": g.nt * g.dt_s,
            "width_y_m": (g.ny - 1) * g.dy_m,
            "height_z_m": (g.nz - 1) * g.dz_m,
            "chunk_t": self.chunk_t,
            "U_m_s": self.U_m_s,
            "hub_height_m": self.hub_height_m,
            "seed": self.seed,
            "frame": a["frame"],
            "frame_note": a["frame_note"],
            "parameters": a["parameters"],
            "units": a["units"],
            "size_on_disk_bytes": self.nbytes_on_disk(),
            "size_uncompressed_bytes": 3 * g.nbytes_per_component(),
            "warnings": spread_warnings(a),
        } | ({} if "constraints" not in a else {"constraints": _constraints_summary(a["constraints"])})


def _constraints_summary(c) -> dict:
    """What ``turbgen info`` shows of a constrained store's ``constraints`` record (its data left out)."""
    return {
        "kind": c["kind"], "files": c["files"], "conditional_mean": c["conditional_mean"],
        "series": [{k: s[k] for k in ("name", "component", "x_m", "y_m", "z_m", "noise_m_s")} for s in c["streams"]],
        "n_samples": c["n_samples"], "solver": c["solver"], "residual_max_m_s": c["residual_max_m_s"],
        "residual_rms_m_s": c["residual_rms_m_s"],
    }  # fmt: skip


def _leftover_hint(path: Path) -> str:
    if not path.parent.is_dir():
        return ""
    left = sorted(p.name for p in path.parent.iterdir() if p.name.startswith(temp_prefix(path)))
    for name in left:
        parsed = parse_temp(name)
        if parsed and pid_alive(parsed[1]):
            return f" (process {parsed[1]} is writing it now)"
    if left:
        return f" (an interrupted write left {path.parent / left[0]}; the next write or `turbgen info` removes it)"
    return ""


def _metadata_json(arr: zarr.Array) -> bytes:
    return arr.metadata.to_buffer_dict(default_buffer_prototype())["zarr.json"].to_bytes()


def _check_array_metadata(path: Path, name: str, group: zarr.Group, own: zarr.Group) -> None:
    """StoreError unless array ``name`` read from its own zarr.json (``own``: the group opened unconsolidated) is
    the array in the root's consolidated copy (``group``). Readers go by the consolidated copy, so a garbage
    ``u/zarr.json`` would pass info, validate and export while any reader of the array itself fails on it."""
    try:
        meta = _metadata_json(own[name])
    except KeyError:
        raise StoreError(f"{path} is incomplete: {name}/zarr.json is missing (partial copy?)") from None
    except Exception as exc:
        raise StoreError(f"{path} is corrupted: {name}/zarr.json unreadable ({type(exc).__name__})") from None
    consolidated = group.get(name)
    if not isinstance(consolidated, zarr.Array) or _metadata_json(consolidated) != meta:
        raise StoreError(f"{path} is corrupted: {name}/zarr.json differs from the metadata consolidated in zarr.json")


def _check_arrays(path: Path, group: zarr.Group, grid: Grid) -> None:
    own = zarr.open_group(str(path), mode="r", zarr_format=3, use_consolidated=False)
    for name in (*layout.COMPONENTS, *layout.DIMS):
        _check_array_metadata(path, name, group, own)
    for c in layout.COMPONENTS:
        arr = group[c]
        if arr.shape != grid.shape or arr.dtype != np.dtype(layout.DTYPE):
            raise StoreError(f"{path} is corrupted: {c} has shape {arr.shape} {arr.dtype}, the grid needs {grid.shape} "
                             f"{layout.DTYPE}")
        if tuple(arr.metadata.dimension_names or ()) != layout.DIMS or arr.chunks[1] != 1:
            raise StoreError(f"{path} is corrupted: {c} has dims {arr.metadata.dimension_names}, chunks {arr.chunks}")
        expected, found = layout.n_chunks(grid, arr.chunks[0]), arr.nchunks_initialized
        if found != expected:
            raise StoreError(f"{path} is incomplete: {c} has {found} of {expected} chunk files (partial copy?); "
                             "copy it again or regenerate it")
    for name, values in layout.coordinates(grid).items():
        arr = group[name]
        if arr.shape != values.shape:
            raise StoreError(f"{path} is corrupted: coordinate {name!r} is missing or has the wrong length")
        if not np.allclose(arr[:], values, rtol=1e-9, atol=1e-9):
            raise StoreError(f"{path} is corrupted: coordinate {name!r} does not match the grid attributes")


def chunks_written(path) -> int:
    """Chunks of u, v, w written so far to the store at ``path``, complete or being written: the files under their
    ``c/`` folders (zarr v3's chunk keys): the count of zarr's ``nchunks_initialized``, which is slower (it matches
    every possible chunk key against the listing) for the service's progress of every running run."""
    return sum(len(files) for c in layout.COMPONENTS for _, _, files in os.walk(Path(path) / c / "c"))


def checked_grid(attrs: dict, where: str) -> Grid:
    """The grid of field attributes ``attrs`` once they pass the layout and plausibility checks; StoreError
    starting with ``where`` otherwise."""
    layout.validate_attrs(attrs, where=where, error=StoreError)
    check_attributes(attrs, where=where)
    try:
        return layout.grid_from_attrs(attrs["grid"])
    except ParameterError as exc:
        raise StoreError(f"{where}: grid attribute: {exc}") from None


def open_store(path) -> FieldStore:
    """Open the complete turbgen field store at ``path`` read-only; one-line StoreError otherwise.

    Checks, in order: the path exists; it is a zarr v3 group written by turbgen; the completeness marker is set;
    the attributes match ``schemas/field.schema.json`` and the plausible ranges; every array's own metadata is the
    consolidated copy; u, v, w and the coordinates have the grid's shapes, dtypes and values; every chunk is present
    (a partial copy is refused). ``~`` in ``path`` is expanded."""
    path = Path(path).expanduser().absolute()
    if not path.exists():
        raise StoreError(f"{path}: no such store{_leftover_hint(path)}")
    if not path.is_dir():
        raise StoreError(f"{path} is a file, not a turbgen store (a zarr directory)")
    layout.silence_consolidated_metadata_warning()
    try:
        group = zarr.open_group(str(path), mode="r", zarr_format=3)
        attrs = group.attrs.asdict()
    except zarr.errors.GroupNotFoundError:
        raise StoreError(f"{path} is not a turbgen store (no zarr.json)") from None
    except zarr.errors.ContainsArrayError:
        raise StoreError(f"{path} is a zarr array but not a turbgen store") from None
    except Exception as exc:  # garbage JSON, metadata zarr does not accept
        raise StoreError(f"{path} is corrupted: zarr.json unreadable ({type(exc).__name__})") from None
    if "turbgen_version" not in attrs:
        raise StoreError(f"{path} is a zarr group but not a turbgen store")
    if attrs.get(layout.MARKER) is not True:
        raise StoreError(f"{path} is incomplete (no completeness marker: the write was interrupted or the copy is "
                         "partial); regenerate it")
    grid = checked_grid(attrs, f"{path} is corrupted")
    try:
        _check_arrays(path, group, grid)
    except StoreError:
        raise
    except Exception as exc:  # any zarr/JSON failure inside the store is corruption
        first = str(exc).splitlines()[0] if str(exc) else ""
        raise StoreError(f"{path} is corrupted: {type(exc).__name__}: {first[:160]}") from None
    return FieldStore(path, grid, attrs, group)


def physical_time_view(path_or_fs):
    """The store as an ``xarray.Dataset`` with an extra 2-D coordinate ``T(t, x) = t - x/U`` [s].

    The stored sample (t, x) is the field at plane x at physical time T = t - x/U (convected frame), so
    ``ds.u.isel(x=i)`` against ``ds.T.isel(x=i)`` is the time series a sensor at plane i sees. Data stay lazy
    (dask). ``path_or_fs`` is a FieldStore or a path for :func:`open_store` (StoreError)."""
    import xarray as xr

    fs = path_or_fs if isinstance(path_or_fs, FieldStore) else open_store(path_or_fs)
    ds = xr.open_zarr(str(fs.path), consolidated=True)
    T = fs.grid.t()[:, None] - fs.grid.x()[None, :] / fs.U_m_s
    return ds.assign_coords(T=(("t", "x"), T, {"units": "s", "long_name": "physical time at plane x: T = t - x/U"}))
