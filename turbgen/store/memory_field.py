"""A field held in memory (an ``xarray.Dataset``) read through the interface of an opened store.

``chunk_t`` is the chunk length the same field's store would have, so span-by-span reads give the same numbers."""

from __future__ import annotations

import numpy as np

from turbgen.errors import StoreError
from turbgen.store import layout
from turbgen.store.plausibility import check_amplitudes
from turbgen.store.reader import FieldStore, checked_grid

LABEL = "the field in memory"


class MemoryField(FieldStore):
    """A complete field in memory with the reading interface of :class:`turbgen.store.FieldStore` (``path`` None)."""

    def __init__(self, grid, attrs: dict, arrays: dict[str, np.ndarray]):
        super().__init__(None, grid, attrs, arrays)  # type: ignore[arg-type]

    def __repr__(self) -> str:
        return f"MemoryField(model={self.model!r}, shape={self.grid.shape})"

    @property
    def label(self) -> str:
        """How messages and reports name the field: "the field in memory"."""
        return LABEL

    @property
    def chunk_t(self) -> int:
        """Time samples per span read at once: the default chunk length of a store of this grid."""
        return layout.default_chunk_t(self.grid.nt)

    def dask(self, component: str):
        """``component`` as a dask array in ``chunk_t`` spans (t, x, y, z)."""
        import dask.array as da

        return da.from_array(self.array(component), chunks=(self.chunk_t, 1, self.grid.ny, self.grid.nz))

    def read_span(self, component: str, ix: int, t0: int, t1: int, out: np.ndarray | None = None) -> np.ndarray:
        """Plane ``ix`` of ``component`` over t in [t0, t1), float32 (t, ny, nz), checked as a store's read is."""
        block = self.array(component)[t0:t1, ix]
        out = np.array(block, dtype=np.float32, order="C") if out is None else _copied(block, out)
        bad = ~np.isfinite(out)
        if bad.any():
            it, iy, iz = (int(i) for i in np.argwhere(bad)[0])
            raise StoreError(f"{LABEL}: non-finite value at {component}, plane index {ix}, t index {t0 + it}, "
                             f"y index {iy}, z index {iz}")  # fmt: skip
        check_amplitudes(out, component, self._limits[component], LABEL, ix, t0, self.chunk_t)
        return out

    def nbytes_on_disk(self) -> int:
        """0: nothing of the field is on disk."""
        return 0

    def summary(self) -> dict:
        """What :meth:`FieldStore.summary` gives (``turbgen info``), ``path`` None and no bytes on disk."""
        return {**super().summary(), "path": None, "size_on_disk_bytes": 0}


def _copied(block: np.ndarray, out: np.ndarray) -> np.ndarray:
    if out.shape != block.shape or out.dtype != np.float32 or not out.flags.c_contiguous:
        raise ValueError(f"out must be C-contiguous float32 of shape {block.shape}")
    out[...] = block
    return out


def memory_field(ds) -> MemoryField:
    """The field of the Dataset ``ds`` (u, v, w float32 with a store's attributes), checked as open_store checks.

    StoreError when it lacks a turbgen field's attributes, components or coordinates, or they do not match its grid.

    Examples
    --------
    >>> import turbgen
    >>> from turbgen.store.memory_field import memory_field
    >>> fs = memory_field(turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 50]))
    >>> fs.model, fs.grid.shape, fs.read_span("u", 1, 0, 8).shape
    ('kaimal', (64, 2, 4, 4), (8, 4, 4))
    """
    attrs = dict(getattr(ds, "attrs", {}))
    if attrs.get(layout.MARKER) is not True or "turbgen_version" not in attrs:
        raise StoreError(f"{LABEL} is not a complete turbgen field (no turbgen attributes: make it with turbgen.mann, "
                         "turbgen.kaimal or a generator, or open a store with turbgen.open_store)")  # fmt: skip
    grid = checked_grid(attrs, f"{LABEL} is not a valid turbgen field")
    arrays = {}
    for c in layout.COMPONENTS:
        var = ds.variables.get(c)
        if var is None or tuple(var.dims) != layout.DIMS or var.shape != grid.shape or var.dtype != layout.DTYPE:
            found = "missing" if var is None else f"{var.dims} {var.shape} {var.dtype}"
            raise StoreError(f"{LABEL}: component {c} is {found}; the grid needs {layout.DIMS} {grid.shape} "
                             f"{layout.DTYPE}")  # fmt: skip
        arrays[c] = np.asarray(var.values)
    for name, values in layout.coordinates(grid).items():
        coord = ds.variables.get(name)
        if coord is None or coord.shape != values.shape or not np.allclose(coord.values, values, rtol=1e-9, atol=1e-9):
            raise StoreError(f"{LABEL}: coordinate {name!r} is missing or does not match the grid attributes")
    return MemoryField(grid, attrs, arrays)
