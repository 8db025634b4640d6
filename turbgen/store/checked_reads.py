"""Reading a plane of a store chunk by chunk with its data checked: a chunk that does not decode or holds NaN/inf
is a one-line StoreError naming the component, plane, time index and chunk file."""

from __future__ import annotations

import numpy as np
import zarr
from zarr.buffer import default_buffer_prototype

from turbgen.errors import StoreError
from turbgen.store.chunk_files import read_chunk


def read_checked(arr: zarr.Array, ix: int, t0: int, t1: int, path=None, out: np.ndarray | None = None) -> np.ndarray:
    """Plane ``ix`` of a component array over t in [t0, t1), float32 (t1 - t0, ny, nz) [m/s], one chunk at a time;
    ``out``: a reused C-contiguous buffer (saves fresh pages per read); ``path`` names the store in messages."""
    name = arr.basename
    where = path if path is not None else getattr(arr.store, "root", None) or "store"
    if out is None:
        out = np.empty((t1 - t0, *arr.shape[2:]), dtype=np.float32)
    elif out.shape != (t1 - t0, *arr.shape[2:]) or out.dtype != np.float32 or not out.flags.c_contiguous:
        raise ValueError(f"out must be C-contiguous float32 of shape {(t1 - t0, *arr.shape[2:])}")
    nd_buffer = default_buffer_prototype().nd_buffer
    step = arr.chunks[0]
    starts = [t0, *range(t0 - t0 % step + step, t1, step)]  # t0, then the chunk starts after it
    for a, b in zip(starts, [*starts[1:], t1]):
        chunk_file = f"{name}/{arr.metadata.encode_chunk_key((a // step, ix, 0, 0))}"
        block = out[a - t0 : b - t0]
        try:
            if not (a % step == 0 and b - a == step and read_chunk(arr, (a // step, ix, 0, 0), block)):
                arr.get_basic_selection((slice(a, b), ix), out=nd_buffer.from_numpy_array(block))
        except Exception as exc:  # a decompression/decoding failure inside zarr, a missing or short chunk file
            raise StoreError(f"{where}: corrupted chunk at {name}, plane index {ix}, t index {a - a % step}-{b - 1} "
                             f"(file {chunk_file}: {type(exc).__name__}); regenerate the store") from None
        bad = ~np.isfinite(block)
        if bad.any():
            it, iy, iz = (int(i) for i in np.argwhere(bad)[0])
            what = "NaN" if np.isnan(block[it, iy, iz]) else "inf"
            raise StoreError(f"{where}: {what} at {name}, plane index {ix}, t index {a + it}, y index {iy}, z index "
                             f"{iz} ({int(bad.sum())} non-finite values in chunk file {chunk_file}); the data are "
                             "corrupted, regenerate the store")
    return out
