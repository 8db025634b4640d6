"""On-disk cache of ae-free Mann stencils (``turbgen mann --stencil-cache DIR``): one .npz per parameter set and box.

The file name is the hash of everything the unit stencil depends on (synthesis.mann_stencil.stencil_key:
all parameters but ae), so a cache entry can never serve another parameter set, and serves every ae
(synthesis.mann_stencil.scale_stencil). Entries are written to a temporary name and renamed; an
unreadable or mismatched entry is rebuilt and replaced.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from turbgen.store.temporaries import temp_name
from turbgen.synthesis.mann_stencil import (
    BoxShape,
    MannStencil,
    UnitMannStencil,
    build_unit_stencil,
    scale_stencil,
    stencil_key,
    unit_stencil_nbytes,
)
from turbgen.theory.params import MannParams


def cached_unit_stencil(
    params: MannParams, box: BoxShape, cache_dir: str | Path, *, evolving: bool = True
) -> UnitMannStencil:
    """The ae-free stencil of ``params`` on ``box``, loaded from ``cache_dir`` or built and saved there."""
    with_tau = evolving and params.evo_time_s is not None
    path = Path(cache_dir) / f"mann-stencil-{stencil_key(params, box, with_tau)}.npz"
    if path.exists():
        try:
            with np.load(path) as data:
                factors = data["factors"]
                inv_tau = data["inv_tau"] if with_tau else None
            if factors.shape == (4, box.nk1, box.nk2_half, box.nzp) and factors.dtype == np.float64:
                return UnitMannStencil(params.with_ae(1.0), box, factors, inv_tau)
        except (OSError, ValueError, KeyError):
            pass  # unreadable cache entry: rebuild and replace it
    unit = build_unit_stencil(params, box, evolving=evolving)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_name(path)
    arrays = {"factors": unit.factors}
    if with_tau:
        arrays["inv_tau"] = unit.inv_tau
    try:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return unit


def shared_stencil_key(run) -> tuple:
    """What the unit stencil of a Mann ``run`` (params, box, grid) depends on: runs with equal keys share it."""
    return run.params.with_ae(1.0), run.box, run.grid.nx > 1


def shared_stencil_nbytes(run) -> int:
    """Bytes of the unit stencil of a Mann ``run`` (held besides the run's own scaled stencil)."""
    return unit_stencil_nbytes(run.box, run.grid.nx > 1 and run.params.evo_time_s is not None)


def build_shared_stencil(run, cache_dir: str | Path | None = None) -> UnitMannStencil:
    """The unit stencil of a Mann ``run`` (params, box, grid), for all runs of its shared_stencil_key."""
    evolving = run.grid.nx > 1
    if cache_dir is None:
        return build_unit_stencil(run.params, run.box, evolving=evolving)
    return cached_unit_stencil(run.params, run.box, cache_dir, evolving=evolving)


def cached_stencil(params: MannParams, box: BoxShape, cache_dir: str | Path, *, evolving: bool = True) -> MannStencil:
    """The stencil of ``params`` on ``box`` (ae included), from the cached ae-free stencil."""
    return scale_stencil(cached_unit_stencil(params, box, cache_dir, evolving=evolving), params)
