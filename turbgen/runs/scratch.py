"""File-backed spectrum buffer for Kaimal runs whose spectrum does not fit in memory: an unlinked temporary file
next to the store, written chunk by chunk and read plane by plane (unwritten bins read as zero)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Self

import numpy as np

ITEM = np.dtype(np.complex64).itemsize


def write_at(fd: int, data: np.ndarray, offset: int) -> None:
    """Write the bytes of ``data`` at byte ``offset`` of the open file ``fd`` (pwrite: no mapping, no RSS)."""
    view = memoryview(np.ascontiguousarray(data)).cast("B")
    while view:
        n = os.pwrite(fd, view, offset)
        view, offset = view[n:], offset + n


def read_at(fd: int, out: np.ndarray, offset: int) -> np.ndarray:
    """Fill the contiguous array ``out`` from byte ``offset`` of ``fd``; OSError if the file ends first."""
    view = memoryview(out).cast("B")
    while view:
        n = os.preadv(fd, [view], offset)
        if n == 0:
            raise OSError("scratch file is shorter than expected")
        view, offset = view[n:], offset + n
    return out


class ScratchFile:
    """An open file ``fd`` written and read by byte offsets (no mapping, not in RSS); a context manager."""

    def __init__(self, fd: int):
        self.fd = fd

    def write(self, offset: int, data: np.ndarray) -> None:
        write_at(self.fd, data, offset)

    def read(self, offset: int, out: np.ndarray) -> np.ndarray:
        return read_at(self.fd, out, offset)

    def close(self) -> None:
        """Close the file (once)."""
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class FileSpectrum(ScratchFile):
    """Spectrum buffer (n_planes, nf, ny, nz) complex64 in a temporary file (a context manager)."""

    def __init__(self, directory: str | Path, nx: int, nf: int, ny: int, nz: int):
        self.nx, self.nf, self.point = nx, nf, ny * nz
        self.shape = (nf, ny, nz)
        fd, name = tempfile.mkstemp(prefix=".turbgen-spectrum-", dir=directory)
        os.unlink(name)  # the space is freed when the file is closed, even after a crash
        super().__init__(fd)
        os.ftruncate(fd, nx * nf * self.point * ITEM)  # sparse: unwritten bins read as zeros

    def put(self, plane: int, k0: int, block: np.ndarray) -> None:
        """Store bins k0 .. k0 + len(block) of ``plane``."""
        self.write((plane * self.nf + k0) * self.point * ITEM, np.asarray(block, dtype=np.complex64))

    def chunk(self, k0: int, k1: int) -> np.ndarray:
        """Where bins k0 .. k1 - 1 of all planes are made (nx, k1 - k0, ny, nz): a fresh array."""
        return np.empty((self.nx, k1 - k0, *self.shape[1:]), dtype=np.complex64)

    def put_chunk(self, k0: int, block: np.ndarray) -> None:
        """Store ``block`` (nx, nb, ny, nz) as bins k0 .. k0 + nb of every plane."""
        for plane in range(self.nx):
            self.put(plane, k0, block[plane])

    def get(self, plane: int) -> np.ndarray:
        """All bins of ``plane`` (nf, ny, nz), a fresh array."""
        return self.read(plane * self.nf * self.point * ITEM, np.empty(self.shape, dtype=np.complex64))
