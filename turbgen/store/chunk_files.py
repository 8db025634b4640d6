"""Raw chunk files of uncompressed stores, written and read with direct I/O (O_DIRECT) where the file system
allows it, bypassing the page cache.

An uncompressed float32 chunk of a zarr v3 array with the little-endian ``bytes`` codec is a file holding
exactly the chunk's C-order bytes (``<array>/c/<it>/<ix>/0/0`` with the default "/" chunk key encoding),
so the writer and the validator may move those bytes themselves. Why: filling the page cache (allocating and
copying into fresh page-cache pages) is the most expensive step of writing a field, while direct I/O moves the
same bytes with little CPU, time a background writer thread overlaps with the synthesis (the measurements:
benchmarks/README.md, "Measurements behind design choices"). :func:`raw_chunk_path` is the one place that relies
on zarr's v3 on-disk layout (the Zarr v3 specification's chunk key encoding and ``bytes`` codec, no private zarr
API); tests/store/test_chunk_files.py compares the files with the ones zarr itself writes, so a zarr that lays
chunks out otherwise fails there.

Direct I/O needs the buffer address, the file offset and the length to be multiples of the device's
logical block: data that are not (a chunk of 31 x 31 points, an unaligned array) pass through a
page-aligned bounce buffer, padded to a whole block and the file then truncated to its true length.
Where the file system refuses O_DIRECT (tmpfs, some network file systems) the ordinary buffered calls
are used. The bytes in the file are the same either way.
"""

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


def raw_chunk_path(array, coords: tuple[int, ...]) -> Path | None:
    """The file of chunk ``coords`` of a zarr array if it holds the chunk's raw C-order bytes in this
    machine's byte order (local store, no filters or compressors, ``bytes`` codec), else None.

    Parameters
    ----------
    array : zarr.Array
        A zarr v3 array.
    coords : tuple of int
        Chunk grid coordinates.

    Returns
    -------
    pathlib.Path or None
        The chunk file (it may not exist yet).
    """
    from zarr.codecs import BytesCodec
    from zarr.storage import LocalStore

    serializer = getattr(array, "serializer", None)
    if (array.metadata.zarr_format != 3 or not isinstance(array.store, LocalStore) or array.compressors
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
    """An uninitialised C-contiguous array whose data start on a page boundary (chunks of it whose byte
    offsets and lengths are multiples of 4096 go to and from disk without a bounce copy).

    Parameters
    ----------
    shape : tuple of int
        Array shape.
    dtype : numpy dtype, optional
        Element type (default float32).

    Returns
    -------
    numpy.ndarray
        The array (its memory is an anonymous mapping, released with the array).
    """
    nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
    return np.frombuffer(mmap.mmap(-1, _round_up(max(nbytes, 1))), np.uint8)[:nbytes].view(dtype).reshape(shape)


def _write_all(fd: int, view: memoryview) -> None:
    done = 0
    while done < len(view):
        done += os.write(fd, view[done:])


def _read_all(fd: int, view: memoryview) -> int:
    done = 0
    while done < len(view):
        got = os.readv(fd, [view[done:]])
        if got == 0:
            break
        done += got
    return done


def write_chunk_file(path: Path, data: np.ndarray) -> None:
    """Write the C-order bytes of ``data`` as the file ``path`` (parents created, an old file replaced).

    Parameters
    ----------
    path : pathlib.Path
        The chunk file.
    data : numpy.ndarray
        The chunk, any layout (a non-contiguous array is written in C order).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    data = np.ascontiguousarray(data)
    nbytes = data.nbytes
    direct = oscalls.direct_io_flag()
    if direct and nbytes:
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | direct, 0o644)
        except OSError as exc:
            if exc.errno not in _REFUSED:
                raise
        else:
            try:
                if _aligned(data):
                    _write_all(fd, memoryview(data.reshape(-1).view(np.uint8)))
                else:
                    padded = _round_up(nbytes)
                    buf = _bounce(padded)
                    buf[:nbytes] = data.reshape(-1).view(np.uint8)
                    buf[nbytes:padded] = 0
                    _write_all(fd, memoryview(buf[:padded]))
                    os.ftruncate(fd, nbytes)
                return
            except OSError as exc:
                if exc.errno not in _REFUSED:
                    raise
            finally:
                os.close(fd)
    with open(path, "wb") as f:  # buffered: no O_DIRECT here, or it was refused
        f.write(memoryview(data.reshape(-1).view(np.uint8)))


def read_chunk_file(path: Path, out: np.ndarray) -> None:
    """Fill ``out`` (C-contiguous) with the bytes of the file ``path``, which must hold exactly ``out.nbytes``.

    Parameters
    ----------
    path : pathlib.Path
        The chunk file.
    out : numpy.ndarray
        C-contiguous destination.

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    ValueError
        When the file's size is not ``out.nbytes``.
    """
    if not out.flags.c_contiguous:
        raise ValueError("read_chunk_file needs a C-contiguous out")
    nbytes = out.nbytes
    size = os.stat(path).st_size
    if size != nbytes:
        raise ValueError(f"{path} holds {size} bytes, a chunk {nbytes}")
    dest = out.reshape(-1).view(np.uint8)
    direct = oscalls.direct_io_flag()
    if direct and nbytes:
        try:
            fd = os.open(path, os.O_RDONLY | direct)
        except OSError as exc:
            if exc.errno not in _REFUSED:
                raise
        else:
            try:
                if _aligned(out):
                    got = _read_all(fd, memoryview(dest))
                else:
                    buf = _bounce(_round_up(nbytes))
                    got = _read_all(fd, memoryview(buf[: _round_up(nbytes)]))
                    dest[:] = buf[:nbytes]
                if got != nbytes:
                    raise ValueError(f"{path}: read {got} of {nbytes} bytes")
                return
            except OSError as exc:
                if exc.errno not in _REFUSED:
                    raise
            finally:
                os.close(fd)
    with open(path, "rb", buffering=0) as f:
        if f.readinto(dest) != nbytes:
            raise ValueError(f"{path}: short read")
