"""On-disk cache of Mann stencils (``turbgen mann --stencil-cache DIR``): one .npz per parameter set and box.

The file name is the hash of everything the stencil depends on (synthesis.mann_stencil.stencil_key),
so a cache entry can never serve another parameter set. Entries are written to a temporary name and
renamed; an unreadable or mismatched entry is rebuilt and replaced.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from turbgen.synthesis.mann_stencil import BoxShape, MannStencil, build_stencil, stencil_key
from turbgen.theory.params import MannParams


def cached_stencil(params: MannParams, box: BoxShape, cache_dir: str | Path, *, evolving: bool = True) -> MannStencil:
    """The stencil of ``params`` on ``box``, loaded from ``cache_dir`` or built and saved there."""
    with_tau = evolving and params.evo_time_s is not None
    path = Path(cache_dir) / f"mann-stencil-{stencil_key(params, box, with_tau)}.npz"
    if path.exists():
        try:
            with np.load(path) as data:
                coef, index, factor = data["coef"], data["cell_index"], data["cell_factor"]
                inv_tau = data["inv_tau"] if with_tau else None
            if coef.shape == (4, box.nk1, box.nk2_half, box.nzp):
                return MannStencil(params, box, coef, inv_tau, index, factor)
        except (OSError, ValueError, KeyError):
            pass  # unreadable cache entry: rebuild and replace it
    stencil = build_stencil(params, box, evolving=evolving)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    arrays = {"coef": stencil.coef, "cell_index": stencil.cell_index, "cell_factor": stencil.cell_factor}
    if with_tau:
        arrays["inv_tau"] = stencil.inv_tau
    with open(tmp, "wb") as f:
        np.savez(f, **arrays)
    os.replace(tmp, path)
    return stencil
