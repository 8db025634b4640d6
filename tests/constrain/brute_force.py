"""Independent references for the conditioning tests: the prior covariance of a tiny Mann field measured as the
generator's response to unit noise vectors (the generator is linear in its noise), and dense Gaussian conditioning.

Nothing here uses turbgen.synthesis.prior_spectrum or conditioning: the covariance comes from the real synthesis
code path (OU recursion, compact factor, axis cells, Hermitian completion, crop, FFTs), one noise coordinate at a
time. Real and imaginary parts of every noise value are independent N(0, 1), so the covariance is the sum of the
responses' outer products.
"""

from __future__ import annotations

import numpy as np

from turbgen.synthesis import mann_spacetime
from turbgen.synthesis.mann_spacetime import COMPONENTS, MannSnapshots


def generator_covariance(monkeypatch, stencil, ny: int, nz: int, times_s) -> np.ndarray:
    """Covariance (N, N) of the stored field flattened as (plane, component, t, y, z), N = P 3 nt ny nz."""
    box = stencil.box
    frozen = stencil.params.evo_time_s is None or len(times_s) == 1
    n_snap = 1 if frozen else len(times_s)
    per_slab = 3 * box.nyp * box.nzp
    target = {}

    def unit_noise(seed, snapshot, slab, out):
        out[...] = 0
        if target.get("key") == (snapshot, slab):
            out.reshape(-1)[target["index"]] = target["value"]
        return out

    monkeypatch.setattr(mann_spacetime, "complex_normal", unit_noise)
    gen = MannSnapshots(stencil, ny, nz, threads=1)
    responses = []
    for m in range(n_snap):
        for slab in range(box.nk1):
            for index in range(per_slab):
                for value in (1.0, 1.0j):
                    target.update(key=(m, slab), index=index, value=value)
                    field = np.zeros((len(times_s), 3, box.nt, ny, nz))
                    for ix, comp, plane in gen.generate(0, times_s):
                        field[ix, COMPONENTS.index(comp)] = plane
                    responses.append(field.ravel())
    a = np.array(responses)
    return a.T @ a


def dense_gain(cov: np.ndarray, h: np.ndarray, noise_var: np.ndarray) -> np.ndarray:
    """K = C H^T (H C H^T + R)^-1 (dense numpy)."""
    s = h @ cov @ h.T + np.diag(noise_var)
    return np.linalg.solve(s, h @ cov).T
