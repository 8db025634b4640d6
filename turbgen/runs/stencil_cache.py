"""On-disk cache of ae-free Mann stencils (``turbgen mann --stencil-cache DIR``): one .npy per parameter set and box.

The file name is the hash of everything the unit stencil depends on (synthesis.mann_stencil.stencil_key:
all parameters but ae), so a cache entry can never serve another parameter set, and serves every ae
(synthesis.unit_stencil.scale_stencil). An entry ``mann-stencil-KEY.npy`` holds the four float64
factors and, for evolving fields, 1/tau_e as a fifth (float64) array; it is built straight into the
file and read back memory-mapped, so the factors never have to be resident. Entries are written to
a temporary name and renamed; an unreadable or mismatched entry is rebuilt and replaced.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np

from turbgen.store.temporaries import temp_name
from turbgen.synthesis.mann_stencil import BoxShape, MannStencil, stencil_key, synthesis_box
from turbgen.synthesis.unit_stencil import UnitMannStencil, build_unit_stencil, scale_stencil, unit_stencil_nbytes
from turbgen.theory.params import MannParams


def cached_unit_stencil(
    params: MannParams, box: BoxShape, cache_dir: str | Path, *, evolving: bool = True
) -> UnitMannStencil:
    """The ae-free stencil of ``params`` on ``box``, read from ``cache_dir`` or built into it.

    Parameters
    ----------
    params : Mann parameters (ae is ignored).
    box : the synthesis box.
    cache_dir : the cache directory (created if missing).
    evolving : False: without 1/tau_e (single snapshots), a separate entry.

    Returns
    -------
    UnitMannStencil : its factors memory-mapped from the entry.
    """
    with_tau = evolving and params.evo_time_s is not None
    path = Path(cache_dir) / f"mann-stencil-{stencil_key(params, box, with_tau)}.npy"
    shape = (5 if with_tau else 4, box.nk1, box.nk2_half, box.nzp)
    try:
        data = np.load(path, mmap_mode="r")
        if data.shape == shape and data.dtype == np.float64:
            with contextlib.suppress(OSError):  # the hit renews the entry's recency (a size-capped cache evicts by it)
                os.utime(path)
            return _unit(params, box, data, with_tau)
    except (OSError, ValueError):
        pass  # missing or unreadable cache entry: rebuild and replace it
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_name(path)
    try:
        mapped = np.lib.format.open_memmap(tmp, mode="w+", dtype=np.float64, shape=shape)
        unit = build_unit_stencil(params, box, evolving=evolving, factors=mapped[:4])
        if with_tau:
            mapped[4] = unit.inv_tau  # float32 -> float64 -> float32 is exact
        mapped.flush()
        del mapped, unit
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return _unit(params, box, np.load(path, mmap_mode="r"), with_tau)


def _unit(params: MannParams, box: BoxShape, data: np.ndarray, with_tau: bool) -> UnitMannStencil:
    """The unit stencil of a mapped cache entry: factors (4, ...) float64 and 1/tau_e as float32 in memory."""
    inv_tau = data[4].astype(np.float32) if with_tau else None
    return UnitMannStencil(params.with_ae(1.0), box, data[:4], inv_tau)


def cached_stencil(params: MannParams, box: BoxShape, cache_dir: str | Path, *, evolving: bool = True) -> MannStencil:
    """The stencil of ``params`` on ``box`` (ae included), scaled from the cached ae-free stencil.

    Parameters
    ----------
    params : Mann parameters, ae [m^(4/3) s^-2] included.
    box : the synthesis box.
    cache_dir : the cache directory.
    evolving : False: without 1/tau_e (single snapshots).

    Returns
    -------
    MannStencil : bit-identical to synthesis.mann_stencil.build_stencil(params, box).
    """
    return scale_stencil(cached_unit_stencil(params, box, cache_dir, evolving=evolving), params)


def shared_stencil_key(run) -> tuple:
    """What the unit stencil of a Mann ``run`` depends on: runs with equal keys share it.

    Parameters
    ----------
    run : a Mann run (its params, box and grid are read).

    Returns
    -------
    tuple : (parameters with ae = 1, box, evolving); hashable.
    """
    return run.params.with_ae(1.0), synthesis_box(run), run.grid.nx > 1


def shared_stencil_nbytes(run) -> int:
    """Bytes [B] of the unit stencil of a Mann ``run`` (held besides the run's own scaled stencil).

    Parameters
    ----------
    run : a Mann run (its params, box and grid are read).

    Returns
    -------
    int
    """
    return unit_stencil_nbytes(synthesis_box(run), run.grid.nx > 1 and run.params.evo_time_s is not None)


def build_shared_stencil(run, cache_dir: str | Path | None = None) -> UnitMannStencil:
    """The unit stencil of a Mann ``run``, for all runs of its shared_stencil_key (run_mann scales it).

    Parameters
    ----------
    run : a Mann run (its params, box and grid are read).
    cache_dir : optional stencil cache directory (cached_unit_stencil).

    Returns
    -------
    UnitMannStencil
    """
    evolving = run.grid.nx > 1
    if cache_dir is None:
        return build_unit_stencil(run.params, synthesis_box(run), evolving=evolving)
    return cached_unit_stencil(run.params, synthesis_box(run), cache_dir, evolving=evolving)
