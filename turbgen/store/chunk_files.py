"""The raw-chunk fast path of the store's I/O: whole chunks of uncompressed stores moved by direct I/O (O_DIRECT).

Where it declines (compressed or foreign-endian array, no O_DIRECT, ``TURBGEN_PORTABLE=1``) zarr's public API does
it; why it stays: benchmarks/bench_store_io.md. An uncompressed ``bytes`` chunk is a file of its C-order bytes at
its chunk key (Zarr v3 specification); unaligned chunks pass through a page-aligned bounce buffer."""

from __future__ import annotations

import errno
import mmap
import os
import sys
import threading
from pathlib import Path

import numpy as np

from turbgen import oscalls

ALIGN = 4096  # a multiple of every logical block size in use (512, 4096)
_REFUSED = (errno.EINVAL, errno.EOPNOTSUPP, errno.ENOTSUP)
_local = threading.local()
RAW = True  # False: every chunk through zarr (benchmarks/bench_store_io.py, the tests comparing both paths)


def raw_chunk_path(array, coords: tuple[int, ...]) -> Path | None:
    """The file of chunk ``coords`` of a zarr ``array`` when it holds the chunk's raw C-order bytes in this
    machine's byte order (v3, local store, no filters or compressors, ``bytes`` codec) and ``RAW`` is set; else None."""
    from zarr.codecs import BytesCodec
    from zarr.storage import LocalStore

    serializer = getattr(array, "serializer", None)
    if (not RAW or array.metadata.zarr_format != 3 or not isinstance(array.store, LocalStore) or array.compressors
            or array.filters or not isinstance(serializer, BytesCodec)
            or (serializer.endian is not None and serializer.endian.value != sys.byteorder)):
        return None
    return Path(array.store.root) / array.path / array.metadata.encode_chunk_key(coords)


def _round_up(n: int) -> int:
    return -(-n // ALIGN) * ALIGN


def _aligned(a: np.ndarray) -> bool:
    return a.ctypes.data % ALIGN == 0 and a.nbytes % ALIGN == 0


def _bounce(nbytes: int) -> np.ndarray:
    """This thread's page-aligned scratch of at least ``nbytes`` bytes (uint8, reused)."""
    buf = getattr(_local, "buf", None)
    if buf is None or buf.size < nbytes:
        _local.buf = buf = np.frombuffer(mmap.mmap(-1, _round_up(max(nbytes, 1))), np.uint8)
    return buf


def empty_aligned(shape, dtype=np.float32) -> np.ndarray:
    """An uninitialised C-contiguous array starting on a page boundary (an anonymous mapping): its whole chunks
    go to and from disk without a bounce copy."""
    nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
    return np.frombuffer(mmap.mmap(-1, _round_up(max(nbytes, 1))), np.uint8)[:nbytes].view(dtype).reshape(shape)


def _direct(array, coords, flags: int, move) -> bool:
    """``move(path, fd)`` on chunk ``coords``' file opened with ``flags | O_DIRECT`` (closed afterwards): True, or
    False where the fast path declines or the file system refuses direct I/O."""
    path, direct = raw_chunk_path(array, coords), oscalls.direct_io_flag()
    if path is None or not direct:
        return False
    if flags & os.O_CREAT:
        path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd = os.open(path, flags | direct, 0o644)
        try:
            move(path, fd)
        finally:
            os.close(fd)
    except OSError as exc:
        if exc.errno in _REFUSED:
            return False
        raise
    return True


def write_chunk(array, coords: tuple[int, ...], data: np.ndarray) -> bool:
    """Write the whole chunk ``coords`` of ``array`` from ``data`` by direct I/O; False where the path declines."""
    data = np.ascontiguousarray(data)
    nbytes, padded = data.nbytes, _round_up(data.nbytes)

    def move(path, fd):
        if _aligned(data):
            view = memoryview(data.reshape(-1).view(np.uint8))
        else:
            buf = _bounce(padded)
            buf[:nbytes] = data.reshape(-1).view(np.uint8)
            buf[nbytes:padded] = 0
            view = memoryview(buf[:padded])
        done = 0
        while done < len(view):
            done += os.write(fd, view[done:])
        os.ftruncate(fd, nbytes)

    return _direct(array, coords, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, move)


def read_chunk(array, coords: tuple[int, ...], out: np.ndarray) -> bool:
    """Fill ``out`` with the whole chunk ``coords`` of ``array`` by direct I/O; False where the path declines;
    FileNotFoundError for a missing file, ValueError for one not of exactly ``out.nbytes`` bytes."""
    nbytes, dest = out.nbytes, out.reshape(-1).view(np.uint8)

    def move(path, fd):
        size = os.fstat(fd).st_size
        if size != nbytes:
            raise ValueError(f"{path} holds {size} bytes, a chunk {nbytes}")
        buf = dest if _aligned(out) else _bounce(_round_up(nbytes))[: _round_up(nbytes)]
        done = 0
        while done < nbytes:
            got = os.readv(fd, [memoryview(buf)[done:]])
            if got == 0:
                raise ValueError(f"{path}: read {done} of {nbytes} bytes")
            done += got
        if buf is not dest:
            dest[:] = buf[:nbytes]

    return _direct(array, coords, os.O_RDONLY, move)
