"""A field kept in memory as the ``xarray.Dataset`` its store would open to: the writer's interface, no file.

The same checks, float32 values and attributes (but ``created_utc``) as :class:`turbgen.store.writer.StoreWriter`.
Used by ``turbgen.mann()`` / ``turbgen.kaimal()`` without ``out``; each plane's (t, y, z) block is contiguous."""

from __future__ import annotations

import json
import threading

import numpy as np

from turbgen.grid import Grid
from turbgen.store import layout
from turbgen.store.attributes import jsonable
from turbgen.store.writer import checked_block, rms_from_squares, validated_caller_attrs, with_writer_attrs


class MemoryWriter:
    """Context manager collecting one field in memory; :attr:`dataset` after its ``with`` block."""

    def __init__(self, grid: Grid, attrs: dict):
        self.grid = grid
        self._attrs = with_writer_attrs(validated_caller_attrs(attrs, grid), grid)
        # plane-major memory: each plane's (t, y, z) block is contiguous, so a generator writes it as it writes its own
        # buffers (a plane of a C-ordered (t, x, y, z) array is strided by nx planes, which slows the generator's
        # transposing copy: benchmarks/README.md, bench_api)
        nt, nx, ny, nz = grid.shape
        self._arrays = {c: np.empty((nx, nt, ny, nz), dtype=np.float32).transpose(1, 0, 2, 3)
                        for c in layout.COMPONENTS}  # fmt: skip
        self._written = {c: np.zeros((grid.nx, grid.nt), dtype=bool) for c in layout.COMPONENTS}
        self._squares: dict[tuple, float] = {}
        self._bookkeeping = threading.Lock()
        self.dataset = None

    def __enter__(self) -> "MemoryWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            self._finish()
        self._arrays = None  # an unfinished field is dropped
        return False

    def add_attrs(self, **attrs) -> None:
        """Add attributes known only after generation, as StoreWriter.add_attrs (ValueError for one already set)."""
        clash = [k for k in attrs if k in self._attrs or k == layout.MARKER]
        if clash:
            raise ValueError(f"store attrs {clash} are already set")
        self._attrs.update(attrs)

    def write(self, component: str, ix: int, data: np.ndarray, t0: int = 0, squares: bool = False):
        """Keep ``data`` (nt_block, ny, nz) as ``component`` at plane ``ix``, time ``t0``: as StoreWriter.write."""
        block, total, sum_sq = checked_block(self.grid, component, ix, data, t0)
        t1 = t0 + block.shape[0]
        dest = self._arrays[component][t0:t1, ix]
        if not _same_array(block, dest):  # not made in place (see plane)
            dest[...] = block
        with self._bookkeeping:
            self._written[component][ix, t0:t1] = True
            self._squares[(component, ix, t0, t1)] = sum_sq
        return (total, sum_sq) if squares else total

    def plane(self, component: str, ix: int) -> np.ndarray:
        """The place (nt, ny, nz) float32 of ``component`` at plane ``ix`` in the field: a generator may write the
        plane there (turbgen.synthesis.mann_spacetime.MannSnapshots.generate's ``target``); :meth:`write` of that
        array then checks and counts it without copying."""
        return self._arrays[component][:, ix]

    def _finish(self) -> None:
        import xarray as xr

        for c, done in self._written.items():
            if not done.all():
                ix, it = np.argwhere(~done)[0]
                raise RuntimeError(f"{c} at plane x = {self.grid.x_m[ix]:g} m was not written from t index {it}")
        attrs = {**self._attrs, layout.RMS_ATTR: rms_from_squares(self._squares, self.grid), layout.MARKER: True}
        coords = {name: (name, values.astype(layout.COORD_DTYPE), dict(layout.COORD_ATTRS[name]))
                  for name, values in layout.coordinates(self.grid).items()}  # fmt: skip
        variables = {c: (layout.DIMS, self._arrays[c], dict(layout.COMPONENT_ATTRS[c])) for c in layout.COMPONENTS}
        # through JSON, as a store's attributes are read back (lists for tuples, plain numbers)
        self.dataset = xr.Dataset(variables, coords=coords, attrs=json.loads(json.dumps(jsonable(attrs), allow_nan=False)))


def _same_array(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether ``a`` and ``b`` are the same values in memory (same start, shape and strides)."""
    return (a.__array_interface__["data"][0] == b.__array_interface__["data"][0] and a.shape == b.shape
            and a.strides == b.strides)  # fmt: skip
