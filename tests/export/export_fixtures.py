"""Small random stores for the export tests (turbgen.store.create_store)."""

from __future__ import annotations

import numpy as np

from turbgen.grid import Grid
from turbgen.store import create_store

SIGMA = {"u": 1.2, "v": 0.9, "w": 0.6}


def make_store(path, *, hub_height_m=20.0, nt=64, x_m=(0.0, 10.0, 25.0), ny=5, nz=7, U_m_s=10.0, seed=1):
    """Store of Gaussian random fluctuations; returns (path, {component: array (nt, nx, ny, nz)})."""
    grid = Grid(nt=nt, dt_s=0.1, x_m=x_m, ny=ny, nz=nz, dy_m=2.0, dz_m=3.0)
    rng = np.random.default_rng(seed)
    data = {c: (s * rng.standard_normal(grid.shape)).astype(np.float32) for c, s in SIGMA.items()}
    attrs = {"model": "kaimal", "parameters": {"sigma_u": 1.2}, "units": {"sigma_u": "m/s"}, "seed": seed,
             "U_m_s": U_m_s, "hub_height_m": hub_height_m}
    with create_store(path, grid, attrs, chunk_t=16) as w:
        for c, arr in data.items():
            for ix in range(grid.nx):
                w.write(c, ix, arr[:, ix])
    return path, data
