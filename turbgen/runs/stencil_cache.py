"""On-disk cache of ae-free Mann stencils (``turbgen mann --stencil-cache DIR``): one .npy per parameter set and box.

A wrapper of synthesis.mann_stencil.build_stencil (the I/O it leaves out). The file name is the hash of everything
the unit stencil depends on (synthesis.mann_stencil.stencil_key: all parameters but ae), so a cache entry can never
serve another parameter set, and serves every ae (MannStencil.scaled). An entry ``mann-stencil-KEY.npy`` holds the
four float64 factors and, for evolving fields, 1/tau_e as a fifth (float64) array; it is built straight into the
file and read back memory-mapped, so the factors never have to be resident. Entries are written to a temporary name
and renamed; an unreadable or mismatched entry is rebuilt and replaced.

The same directory keeps the per-frequency system S - R = H C H^T of constrained runs (:func:`cached_system`,
``mann-stencil-system-KEY.npy``): it depends on the run's model and grid and on the measurement geometry, not on the
seed or the data values, so every seed conditioned on the same measurements reads it instead of computing it again.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import warnings
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np

from turbgen.store.temporaries import temp_name
from turbgen.synthesis.mann_stencil import BoxShape, MannStencil, build_stencil, stencil_key
from turbgen.theory.params import MannParams


def cached_stencil(
    params: MannParams, box: BoxShape, cache_dir: str | Path, *, energy: str = "scaled", evolving: bool = True
) -> MannStencil:
    """The stencil of ``params`` on ``box``, from the unit stencil read from ``cache_dir`` or built into it.

    Parameters
    ----------
    params : MannParams
        Mann parameters, ae [m^(4/3) s^-2] included (used only to scale).
    box : BoxShape
        The synthesis box.
    cache_dir : str or pathlib.Path
        The cache directory (created if missing).
    energy : {"scaled", "unit"}
        "unit": the unit stencil itself, its factors memory-mapped from the entry; "scaled": scaled to ae
        (MannStencil.scaled), bit-identical to build_stencil(params, box).
    evolving : bool
        False: without 1/tau_e (single snapshots), a separate entry.

    Returns
    -------
    MannStencil
    """
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


def _build_entry(params: MannParams, box: BoxShape, path: Path, shape: tuple, evolving: bool) -> None:
    """Build the unit stencil into a temporary file next to ``path``, then rename it to ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_name(path)
    try:
        mapped = np.lib.format.open_memmap(tmp, mode="w+", dtype=np.float64, shape=shape)
        unit = build_stencil(params, box, energy="unit", evolving=evolving, factors=mapped[:4])
        if shape[0] == 5:
            mapped[4] = unit.inv_tau  # float32 -> float64 -> float32 is exact
        mapped.flush()
        del mapped, unit
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _unit(params: MannParams, box: BoxShape, data: np.ndarray, with_tau: bool) -> MannStencil:
    """The unit stencil of a mapped cache entry: factors (4, ...) float64 and 1/tau_e as float32 in memory."""
    inv_tau = data[4].astype(np.float32) if with_tau else None
    return MannStencil(params.with_ae(1.0), box, data[:4], inv_tau, None, None, energy="unit")


SYSTEM_VERSION = 1  # part of a system entry's key: change it when stream_covariance's arithmetic changes


def system_key(params: MannParams, box: BoxShape, with_tau: bool, times_s, arrays: dict) -> str:
    """Hash of everything the system H C H^T of a constrained run depends on (cache file name): every parameter, ae
    included, the box, the planes' relative times [s] and the streams' ``arrays`` (name -> array: planes, terms,
    shifts, weights, decimation, offsets)."""
    h = hashlib.sha256(json.dumps({"v": SYSTEM_VERSION, "params": asdict(params), "box": asdict(box),
                                   "tau": with_tau}, sort_keys=True).encode())  # fmt: skip
    for name, value in sorted({"times_s": np.asarray(times_s, dtype=np.float64), **arrays}.items()):
        a = np.ascontiguousarray(value)
        h.update(f"{name}:{a.dtype.str}:{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()[:24]


def cached_system(cache_dir: str | Path, key: str, shape: tuple[int, ...], compute: Callable[[], np.ndarray]
                  ) -> np.ndarray:  # fmt: skip
    """The system (complex128, ``shape``) of ``key`` read from ``cache_dir``, or ``compute()`` d and stored there
    (a temporary name, then renamed; an unreadable or mismatched entry is computed again and replaced; a cache that
    cannot keep it gives a RuntimeWarning). The entry holds exactly the computed array: a run reading it gets the
    same bits as one computing it."""
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
