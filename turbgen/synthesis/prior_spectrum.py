"""The exact discrete prior of a synthesised Mann field, slab by slab: what conditioning needs from the stencil.

With Phi_i = 2 C C^T, the covariance of two points of planes p, q lagged by (dn, dy, dz) steps is

    Cov(r) = Re sum_i w_i sum_(j, l) rho_pq,i(j, l) Phi_i(j, l) exp(2 pi i (i dn / nt + j dy / nyp + l dz / nzp)),

w_i = 1 on the k1 = 0 and Nyquist slabs, 2 elsewhere, rho_pq = exp(-|t_p - t_q| / tau_e) (Guo et al. 2023,
Eq. 13-14); exact for the periodic box, whose crop is the stored field."""

from __future__ import annotations

import numpy as np

from turbgen.synthesis.mann_stencil import MannStencil, expand_k2


def slab_weight(stencil: MannStencil, i: int) -> float:
    """w_i: 1 on the k1 = 0 and (even nt) Nyquist slabs, 2 on the others (their Hermitian partner slab)."""
    nt = stencil.box.nt
    return 1.0 if i == 0 or (nt % 2 == 0 and i == nt // 2) else 2.0


def slab_inv_tau(stencil: MannStencil, i: int) -> np.ndarray | None:
    """1/tau_e [1/s] of slab ``i`` on all (nyp, nzp) points (float64), or None for a stencil without it."""
    if stencil.inv_tau is None:
        return None
    box = stencil.box
    half = stencil.inv_tau[i - stencil.slab0].astype(float)
    return expand_k2(half, box.nyp, False, np.empty((box.nyp, box.nzp)))

