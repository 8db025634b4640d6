"""The exact second moments of a synthesised Mann field, E[u_hat u_hat^H] = 2 C C^T: the tests' discrete oracle."""

from __future__ import annotations

import numpy as np

from turbgen.synthesis.mann_stencil import _ODD, MannStencil, expand_k2, w_coefficient


def slab_factor(stencil: MannStencil, i: int) -> np.ndarray:
    """The full factor C (3, 3, nyp, nzp) float64 of slab ``i`` of a scaled stencil (ValueError for a unit one)."""
    box = stencil.box
    scratch = None if stencil.coef is not None else np.empty((4, 1, box.nk2_half, box.nzp), np.float32)
    coef, j = stencil.coefficients(i, i + 1, scratch)
    full = [expand_k2(coef[n, j].astype(float), box.nyp, _ODD[n], np.empty((box.nyp, box.nzp))) for n in range(4)]
    a, p, z1, z2 = full
    k1 = box.k1()[i]
    k2 = box.k2()[:, None] * np.ones((1, box.nzp))
    q = k1 * k1 + k2 * k2
    w = w_coefficient(a, p, q, q + box.k3()[None, :] ** 2, np.empty_like(a), np.empty_like(a))
    c = np.zeros((3, 3, box.nyp, box.nzp))
    # u = P n1 - A k2 n2 + Z1 (k2 n0 - k1 n1); v = -P n0 + A k1 n2 + Z2 (k2 n0 - k1 n1); w = W (k2 n0 - k1 n1)
    c[0] = [z1 * k2, p - z1 * k1, -a * k2]
    c[1] = [-p + z2 * k2, -z2 * k1, a * k1]
    c[2] = [w * k2, -w * k1, np.zeros_like(a)]
    cells = stencil.cells_in(i, i + 1)
    rows, cols = stencil.cell_index[cells, 1], stencil.cell_index[cells, 2]
    c[:, :, rows, cols] = np.moveaxis(stencil.cell_factor[cells].astype(float), 0, -1)
    return c

