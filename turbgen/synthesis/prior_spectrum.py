"""The exact discrete prior of a synthesised Mann field, slab by slab: what conditioning needs from the stencil.

The generator (turbgen.synthesis.mann_spacetime) forms u_hat = C n on every point of the half spectrum, with
E|n|^2 = 2, completes the k1 = 0 / Nyquist slabs Hermitian and takes the real inverse FFT (index convention:
u(n, y, z) = sum u_hat_i(j, l) exp(+2 pi i (i n / nt + j y / nyp + l z / nzp))). Hence, with
Phi_i(j, l) = 2 C C^T (3 x 3, real symmetric; the axis cells' factors where they replace the compact one), the
covariance of the field between two points of planes p, q lagged by r = (dn, dy, dz) grid steps is

    Cov(r) = Re sum_i w_i sum_(j, l) rho_pq,i(j, l) Phi_i(j, l) exp(2 pi i (i dn / nt + j dy / nyp + l dz / nzp)),

w_i = 1 on the k1 = 0 and Nyquist slabs and 2 elsewhere, rho_pq = exp(-|t_p - t_q| / tau_e) the Ornstein-Uhlenbeck
factor between snapshots (Guo et al. 2023, Eq. 13-14; 1 for frozen turbulence). This is exact for the periodic
box; the stored field is its crop, so its covariance is the crop of this translation-invariant one.
"""

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

