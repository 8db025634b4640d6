"""The correction C H^T w of a constrained Mann run on disk between its computation (slab groups, all planes) and the
writing pass (plane by plane): (planes, 3, nk1, ny, nz) complex64 in an anonymous file (freed however the run ends)."""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from turbgen.runs.scratch import read_at, write_at


class CorrectionScratch:
    """Cropped spectra (planes, 3, nk1, ny, nz) complex64 in an anonymous file in ``directory`` (a context manager)."""

    def __init__(self, directory: Path, shape: tuple[int, int, int, int, int]):
        self.shape = shape
        self._file = tempfile.TemporaryFile(dir=directory)
        self._point = shape[3] * shape[4] * 8  # bytes of one slab of one plane and component
        self._io: ThreadPoolExecutor | None = None

    def __enter__(self) -> CorrectionScratch:
        return self

    def __exit__(self, *exc) -> None:
        if self._io is not None:
            self._io.shutdown(wait=True, cancel_futures=True)
        self._file.close()

    @staticmethod
    def nbytes(shape: tuple[int, ...]) -> int:
        """The file's size [bytes] for spectra of ``shape``."""
        return int(np.prod(shape)) * 8

    def _offset(self, plane: int, component: int, slab: int) -> int:
        return ((plane * 3 + component) * self.shape[2] + slab) * self._point

    def write(self, slabs: range, block: np.ndarray) -> None:
        """Store ``block`` (planes, 3, len(slabs), ny, nz) complex64 at ``slabs``."""
        fd = self._file.fileno()
        for p in range(block.shape[0]):
            for c in range(3):
                write_at(fd, np.asarray(block[p, c], dtype=np.complex64), self._offset(p, c, slabs.start))

    def read(self, plane: int, component: int, out: np.ndarray | None = None) -> np.ndarray:
        """The spectra (nk1, ny, nz) of ``component`` on stored plane ``plane`` (into ``out`` if given)."""
        out = np.empty(self.shape[2:], np.complex64) if out is None else out
        return read_at(self._file.fileno(), out, self._offset(plane, component, 0))

    def reader(self, keys: Iterable[tuple[int, int]]) -> Callable[[int, int], np.ndarray]:
        """A function (plane, component) -> :meth:`read`, called for ``keys`` in that order, each read
        ahead in a background thread; two buffers alternate (an array is valid until the next call)."""
        keys = list(keys)
        if self._io is None:
            self._io = ThreadPoolExecutor(1, thread_name_prefix="turbgen-correction-read")
        buffers = [np.empty(self.shape[2:], np.complex64) for _ in range(min(2, len(keys)))]
        state = {"n": 0, "next": self._io.submit(self.read, *keys[0], buffers[0]) if keys else None}

        def read(plane: int, component: int) -> np.ndarray:
            n = state["n"]
            if n >= len(keys) or keys[n] != (plane, component):
                raise ValueError(f"plane {plane} component {component} asked for out of the order given")
            out = state["next"].result()
            if n + 1 < len(keys):  # into the buffer of call n - 1, no longer in use
                state["next"] = self._io.submit(self.read, *keys[n + 1], buffers[(n + 1) % 2])
            state["n"] = n + 1
            return out

        return read
