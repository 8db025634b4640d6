"""Opening a field store: refuse anything that is not a complete, consistent turbgen store.

``open_store(path)`` checks, in order: the path exists; it is a zarr v3 group written by turbgen;
the completeness marker is set; the attributes match ``schemas/field.schema.json``; the arrays
u, v, w and coordinates t, x, y, z exist with the grid's shapes, dtypes and values; and every
chunk file is present (a partially copied store is refused). Each failure is one-line StoreError.
Data are checked as they are read (:func:`read_checked`): a chunk that does not decode (truncated,
overwritten) or holds NaN (the writer never stores NaN or inf) is reported as "corrupted chunk at
..." / "NaN at ..." naming the component, plane, time index and chunk file; attributes out of the allowed
ranges and values beyond 100 times the recorded rms are refused too (``plausibility``).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import zarr

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
        g = self.grid
        return f"FieldStore({str(self.path)!r}, model={self.model!r}, shape={g.shape})"

    @property
    def label(self) -> str:
        """How messages and reports name the field: the store's path.

        Returns
        -------
        str
            The store's path.
        """
        return str(self.path)

    @property
    def model(self) -> str:
        """The turbulence model of the field.

        Returns
        -------
        str
            "mann" or "kaimal".
        """
        return self.attrs["model"]

    @property
    def U_m_s(self) -> float:
        """Mean wind speed [m/s].

        Returns
        -------
        float
            Mean wind speed [m/s] (attribute U_m_s).
        """
        return float(self.attrs["U_m_s"])

    @property
    def hub_height_m(self) -> float:
        """Hub height above ground [m].

        Returns
        -------
        float
            Hub height above ground [m] (attribute hub_height_m).
        """
        return float(self.attrs["hub_height_m"])

    @property
    def seed(self) -> int:
        """Random seed of the field.

        Returns
        -------
        int
            The seed (attribute seed).
        """
        return int(self.attrs["seed"])

    @property
    def chunk_t(self) -> int:
        """Time-chunk length of the u, v, w arrays.

        Returns
        -------
        int
            Time samples per chunk.
        """
        return int(self.array("u").chunks[0])

    def array(self, component: str) -> zarr.Array:
        """The zarr array of ``component`` ("u", "v" or "w"), dims (t, x, y, z), read-only.

        Parameters
        ----------
        component : str
            "u", "v" or "w".

        Returns
        -------
        zarr.Array
            float32 array (nt, nx, ny, nz) of the velocity fluctuations [m/s]. Reading it directly does
            not check the data (use :meth:`read_plane` or :func:`read_checked`).

        Raises
        ------
        ParameterError
            For an unknown component.
        """
        if component not in layout.COMPONENTS:
            raise ParameterError(f"component = {component!r} is not one of {', '.join(layout.COMPONENTS)}")
        return self._group[component]

    def dask(self, component: str):
        """``component`` as a dask array with the stored chunks (t, x, y, z).

        Parameters
        ----------
        component : str
            "u", "v" or "w".

        Returns
        -------
        dask.array.Array
            Lazy float32 array (nt, nx, ny, nz) [m/s].

        Raises
        ------
        ParameterError
            For an unknown component.
        """
        import dask.array as da

        arr = self.array(component)
        return da.from_zarr(arr, chunks=arr.chunks)

    def read_plane(self, component: str, ix: int) -> np.ndarray:
        """One yz-plane time series, float32 array (nt, ny, nz), of plane index ``ix``.

        Read and checked chunk by chunk (:func:`read_checked`).

        Parameters
        ----------
        component : str
            "u", "v" or "w".
        ix : int
            Plane index in [0, nx - 1].

        Returns
        -------
        numpy.ndarray
            float32 array (nt, ny, nz) of velocity fluctuations [m/s].

        Raises
        ------
        ParameterError
            For an unknown component or a plane index out of range.
        StoreError
            For a corrupted chunk, one holding NaN/inf or an implausible value.
        """
        if not 0 <= ix < self.grid.nx:
            raise ParameterError(f"plane index = {ix} is outside [0, {self.grid.nx - 1}]")
        return self.read_span(component, ix, 0, self.grid.nt)

    def read_span(self, component: str, ix: int, t0: int, t1: int, out: np.ndarray | None = None) -> np.ndarray:
        """Plane ``ix`` of ``component`` over t in [t0, t1), float32 (t, ny, nz), read and checked chunk by chunk.

        A chunk must decode and hold finite values (:func:`read_checked`), each no larger in magnitude than
        AMPLITUDE_RMS times the component's recorded rms (:mod:`turbgen.store.plausibility`).

        Parameters
        ----------
        component : str
            "u", "v" or "w".
        ix : int
            Plane index in [0, nx - 1].
        t0, t1 : int
            First and end (exclusive) time index.
        out : numpy.ndarray, optional
            C-contiguous float32 (t1 - t0, ny, nz) buffer the values are decoded into; default a new array.

        Returns
        -------
        numpy.ndarray
            float32 array (t1 - t0, ny, nz) of velocity fluctuations [m/s]: ``out`` if given.

        Raises
        ------
        StoreError
            For a corrupted chunk, one holding NaN/inf or an implausible value.
        """
        arr = self.array(component)
        block = read_checked(arr, ix, t0, t1, self.path, out=out)
        check_amplitudes(block, component, self._limits[component], self.path, ix, t0, arr.chunks[0])
        return block

    def check_chunks(self) -> None:
        """Decode every chunk of u, v, w (StoreError naming the first corrupted chunk or NaN).

        Returns
        -------
        None

        Raises
        ------
        StoreError
            At the first chunk that does not decode, holds NaN/inf or an implausible value.
        """
        for c in layout.COMPONENTS:
            for ix in range(self.grid.nx):
                self.read_plane(c, ix)

    def nbytes_on_disk(self) -> int:
        """Total size of the store's files [bytes].

        Returns
        -------
        int
            Sum of the sizes of all files under the store directory [bytes].
        """
        return sum(f.stat().st_size for f in self.path.rglob("*") if f.is_file())

    def summary(self) -> dict:
        """What ``turbgen info`` shows, as JSON-serialisable values (units in the key names).

        Returns
        -------
        dict
            path, complete, model, turbgen_version, created_utc, grid, shape_t_x_y_z, duration_s [s],
            width_y_m [m], height_z_m [m], chunk_t, U_m_s [m/s], hub_height_m [m], seed, frame,
            frame_note, parameters, units, size_on_disk_bytes and size_uncompressed_bytes [bytes], warnings (an
            implausible recorded rms: :func:`turbgen.store.plausibility.spread_warnings`); ``constraints``
            (series, solver, residual [m/s]) only for a store conditioned on measurements.
        """
        g, a = self.grid, self.attrs
        return {
            "path": str(self.path),
            "complete": True,
            "model": self.model,
            "turbgen_version": a["turbgen_version"],
            "created_utc": a["created_utc"],
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


def _count_files(directory: Path) -> int:
    return sum(len(files) for _, _, files in os.walk(directory))


def _check_array_metadata(path: Path, name: str, consolidated: dict | None) -> None:
    """StoreError unless ``name``/zarr.json is the array's JSON metadata, the same as the root's consolidated copy.

    Readers go by the consolidated copy, so a garbage ``u/zarr.json`` passed info, validate and export, while any
    reader that opens the array itself (zarr without consolidation, other tools) fails on it."""
    meta_file = path / name / "zarr.json"
    if not meta_file.is_file():
        raise StoreError(f"{path} is incomplete: {name}/zarr.json is missing (partial copy?)")
    try:
        meta = json.loads(meta_file.read_text())
    except (OSError, ValueError) as exc:
        raise StoreError(f"{path} is corrupted: {name}/zarr.json unreadable ({type(exc).__name__})") from None
    if consolidated is not None and meta != consolidated.get(name):
        raise StoreError(f"{path} is corrupted: {name}/zarr.json differs from the metadata consolidated in zarr.json")


def _check_arrays(path: Path, group: zarr.Group, grid: Grid, consolidated: dict | None) -> None:
    for name in (*layout.COMPONENTS, *layout.DIMS):
        _check_array_metadata(path, name, consolidated)
    for c in layout.COMPONENTS:
        arr = group.get(c)
        if not isinstance(arr, zarr.Array):
            raise StoreError(f"{path} is corrupted: array {c!r} is missing")
        if arr.shape != grid.shape or arr.dtype != np.dtype(layout.DTYPE):
            raise StoreError(
                f"{path} is corrupted: {c} has shape {arr.shape} {arr.dtype}, "
                f"the grid needs {grid.shape} {layout.DTYPE}"
            )
        if tuple(arr.metadata.dimension_names or ()) != layout.DIMS or arr.chunks[1] != 1:
            raise StoreError(f"{path} is corrupted: {c} has dims {arr.metadata.dimension_names}, chunks {arr.chunks}")
        expected = layout.n_chunks(grid, arr.chunks[0])
        found = _count_files(path / c / "c")
        if found != expected:
            raise StoreError(
                f"{path} is incomplete: {c} has {found} of {expected} chunk files (partial copy?); "
                "copy it again or regenerate it"
            )
    for name, values in layout.coordinates(grid).items():
        arr = group.get(name)
        if not isinstance(arr, zarr.Array) or arr.shape != values.shape:
            raise StoreError(f"{path} is corrupted: coordinate {name!r} is missing or has the wrong length")
        if not np.allclose(arr[:], values, rtol=1e-9, atol=1e-9):
            raise StoreError(f"{path} is corrupted: coordinate {name!r} does not match the grid attributes")


def open_store(path) -> FieldStore:
    """Open the complete turbgen field store at ``path`` read-only; one-line StoreError otherwise.

    Checks, in order: the path exists; it is a zarr v3 group written by turbgen; the completeness
    marker is set; the attributes match ``schemas/field.schema.json``; the arrays u, v, w and the
    coordinates t, x, y, z have the grid's shapes, dtypes and values; every chunk file is present.

    Parameters
    ----------
    path : str or os.PathLike
        The store directory (``~`` is expanded).

    Returns
    -------
    FieldStore
        The validated store.

    Raises
    ------
    StoreError
        When the path is missing, a file, not a turbgen store, incomplete (no marker, missing
        metadata or chunk files) or corrupted (unreadable metadata, invalid attributes or grid,
        wrong arrays or coordinates).
    """
    path = Path(path).expanduser().absolute()
    if not path.exists():
        raise StoreError(f"{path}: no such store{_leftover_hint(path)}")
    if not path.is_dir():
        raise StoreError(f"{path} is a file, not a turbgen store (a zarr directory)")
    meta_file = path / "zarr.json"
    if not meta_file.is_file():
        raise StoreError(f"{path} is not a turbgen store (no zarr.json)")
    try:
        meta = json.loads(meta_file.read_text())
        attrs = meta["attributes"]
        node = meta["node_type"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise StoreError(f"{path} is corrupted: zarr.json unreadable ({type(exc).__name__})") from None
    if node != "group" or not isinstance(attrs, dict) or "turbgen_version" not in attrs:
        raise StoreError(f"{path} is a zarr {node} but not a turbgen store")
    if attrs.get(layout.MARKER) is not True:
        raise StoreError(
            f"{path} is incomplete (no completeness marker: the write was interrupted or the copy is partial); "
            "regenerate it"
        )
    layout.validate_attrs(attrs, where=f"{path} is corrupted", error=StoreError)
    check_attributes(attrs, where=f"{path} is corrupted")
    try:
        grid = layout.grid_from_attrs(attrs["grid"])
    except ParameterError as exc:
        raise StoreError(f"{path} is corrupted: grid attribute: {exc}") from None
    try:
        layout.silence_consolidated_metadata_warning()
        group = zarr.open_group(str(path), mode="r")
        _check_arrays(path, group, grid, (meta.get("consolidated_metadata") or {}).get("metadata"))
    except StoreError:
        raise
    except Exception as exc:  # any zarr/JSON failure inside the store is corruption
        first = str(exc).splitlines()[0] if str(exc) else ""
        raise StoreError(f"{path} is corrupted: {type(exc).__name__}: {first[:160]}") from None
    return FieldStore(path, grid, attrs, group)


def physical_time_view(path_or_fs):
    """The store as an ``xarray.Dataset`` with an extra 2-D coordinate ``T(t, x) = t - x/U`` [s].

    The store is in the convected frame: all planes share one eddy-time axis ``t``. The stored
    sample (t, x) is the field at plane x at physical time T = t - x/U (an eddy at x upstream
    reaches the rotor x/U later), so e.g. ``ds.u.isel(x=i)`` plotted against ``ds.T.isel(x=i)`` is
    the time series a sensor at plane i sees. Data stay lazy (dask).

    Parameters
    ----------
    path_or_fs : str, os.PathLike or FieldStore
        The store, or its path (opened with :func:`open_store`).

    Returns
    -------
    xarray.Dataset
        u, v, w (t, x, y, z) [m/s] with coordinates t [s], x, y, z [m] and T (t, x) [s].

    Raises
    ------
    StoreError
        When a path is given and it is not a complete, valid store.
    """
    import xarray as xr

    fs = path_or_fs if isinstance(path_or_fs, FieldStore) else open_store(path_or_fs)
    ds = xr.open_zarr(str(fs.path), consolidated=True)
    t = fs.grid.t()
    x = fs.grid.x()
    T = t[:, None] - x[None, :] / fs.U_m_s
    return ds.assign_coords(
        T=(("t", "x"), T, {"units": "s", "long_name": "physical time at plane x: T = t - x/U"})
    )
