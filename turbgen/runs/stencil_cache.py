"""On-disk cache of ae-free Mann stencils (``turbgen mann --stencil-cache DIR``): one .npy per parameter set and box.

The file name hashes all the unit stencil depends on (mann_stencil.stencil_key: all parameters but ae), so an entry
serves every ae (MannStencil.scaled) and never another parameter set. ``mann-stencil-KEY.npy`` holds the four float64
factors and, evolving, 1/tau_e; it is written batch by batch into reserved space (never a writable map), under a
temporary name then renamed, and read back memory-mapped. A bad entry is rebuilt; a full disk is a ParameterError.

The directory also keeps the system H C H^T of constrained runs (:func:`cached_system`), which depends on model,
grid and measurement geometry but not on the seed or the data values."""

from __future__ import annotations

import contextlib
import errno
import hashlib
import io
import json
import os
import warnings
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np

from turbgen import oscalls
from turbgen.errors import ParameterError
from turbgen.resources import require_disk
from turbgen.runs.scratch import write_at
from turbgen.store.temporaries import temp_name
from turbgen.synthesis.mann_stencil import BoxShape, MannStencil, build_step, build_stencil, stencil_key
from turbgen.theory.params import MannParams


def cached_stencil(
    params: MannParams, box: BoxShape, cache_dir: str | Path, *, energy: str = "scaled", evolving: bool = True
) -> MannStencil:
    """The stencil of ``params`` on ``box`` from the unit stencil in ``cache_dir`` (read or built into it):
    ``energy`` "unit" memory-mapped, "scaled" to ``params.ae`` (build_stencil's bits); ``evolving`` False: no 1/tau."""
    with_tau = evolving and params.evo_time_s is not None
    path = Path(cache_dir) / f"mann-stencil-{stencil_key(params, box, with_tau)}.npy"
    shape = (5 if with_tau else 4, box.nk1, box.nk2_half, box.nzp)
    unit = None
    try:
        data = np.load(path, mmap_mode="r")
        if data.shape == shape and data.dtype == np.float64:
            with contextlib.suppress(OSError):  # the hit renews the entry's recency (a size-capped cache evicts by it)
                os.utime(path)
            unit = _unit(params, box, data, with_tau)
    except (OSError, ValueError):
        pass  # missing or unreadable cache entry: rebuild and replace it
    if unit is None:
        _build_entry(params, box, path, shape, evolving)
        unit = _unit(params, box, np.load(path, mmap_mode="r"), with_tau)
    return unit if energy == "unit" else unit.scaled(params)


ENTRY_BATCH_BYTES = 64 * 2**20  # an entry is built and written this many bytes of slabs at a time


def _build_entry(params: MannParams, box: BoxShape, path: Path, shape: tuple, evolving: bool) -> None:
    """Build the unit stencil batch by batch into a temporary file next to ``path`` (space reserved first: a
    sparse writable map would turn a full disk into SIGBUS), then rename it; a full disk is a ParameterError."""
    path.parent.mkdir(parents=True, exist_ok=True)
    header = io.BytesIO()
    np.lib.format.write_array_header_2_0(header, {"descr": "<f8", "fortran_order": False, "shape": shape})
    head = header.getvalue()
    slab_bytes = int(np.prod(shape[2:])) * 8
    nbytes = len(head) + shape[0] * shape[1] * slab_bytes
    what, hint = f"the stencil cache entry {path}", "free space or choose another `stencil_cache`"
    require_disk(path.parent, nbytes, what, hint)
    tmp = temp_name(path)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        try:
            oscalls.reserve(fd, nbytes, keep_size=False, name=str(tmp))
            write_at(fd, np.frombuffer(head, np.uint8), 0)
            step = build_step(box)
            batch = max(step, ENTRY_BATCH_BYTES // (shape[0] * slab_bytes) // step * step)
            for i0 in range(0, shape[1], batch):
                i1 = min(i0 + batch, shape[1])
                part = build_stencil(params, box, energy="unit", evolving=evolving, slabs=(i0, i1))
                arrays = list(np.asarray(part.coef))
                if shape[0] == 5:
                    arrays.append(np.asarray(part.inv_tau, dtype=np.float64))
                for j, a in enumerate(arrays):  # float32 -> float64 -> float32 is exact for 1/tau_e
                    write_at(fd, a, len(head) + (j * shape[1] + i0) * slab_bytes)
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise ParameterError(f"{what}: the disk is full ({exc.strerror}); {hint}") from None
        raise
    finally:
        tmp.unlink(missing_ok=True)


def _unit(params: MannParams, box: BoxShape, data: np.ndarray, with_tau: bool) -> MannStencil:
    """The unit stencil of a mapped entry (1/tau_e as float32 in memory)."""
    inv_tau = data[4].astype(np.float32) if with_tau else None
    return MannStencil(params.with_ae(1.0), box, data[:4], inv_tau, None, None, energy="unit")


SYSTEM_VERSION = 1  # part of a system entry's key: change it when stream_covariance's arithmetic changes


def system_key(params: MannParams, box: BoxShape, with_tau: bool, times_s, arrays: dict) -> str:
    """Hash naming the system H C H^T of a constrained run: every parameter (ae included), the box, the planes'
    relative times [s] and the streams' ``arrays``."""
    h = hashlib.sha256(json.dumps({"v": SYSTEM_VERSION, "params": asdict(params), "box": asdict(box),
                                   "tau": with_tau}, sort_keys=True).encode())  # fmt: skip
    for name, value in sorted({"times_s": np.asarray(times_s, dtype=np.float64), **arrays}.items()):
        a = np.ascontiguousarray(value)
        h.update(f"{name}:{a.dtype.str}:{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()[:24]


def cached_system(cache_dir: str | Path, key: str, shape: tuple[int, ...], compute: Callable[[], np.ndarray]
                  ) -> np.ndarray:  # fmt: skip
    """The system (complex128, ``shape``) of ``key`` read from ``cache_dir``, or ``compute()``-d and stored there
    (temporary name, rename; a cache that cannot keep it only warns). The same bits either way."""
    path = Path(cache_dir) / f"mann-stencil-system-{key}.npy"
    try:
        data = np.load(path)
        if data.shape == shape and data.dtype == np.complex128:
            with contextlib.suppress(OSError):  # the hit renews the entry's recency (a size-capped cache evicts by it)
                os.utime(path)
            return data
    except (OSError, ValueError):
        pass  # missing or unreadable entry: computed and replaced
    data = compute()
    tmp = temp_name(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb") as f:
            np.save(f, data)
        os.replace(tmp, path)
    except OSError as exc:  # a cache that cannot keep the entry (full, read-only) does not fail the run
        warnings.warn(f"the stencil cache {cache_dir} did not keep the system ({exc})", RuntimeWarning, stacklevel=2)
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
    return data
