"""The Mann tensor on the (k2, k3) lattice of the generator's periodic box, slab by slab in k1.

The tensor Phi_ij (Mann 1994, Eq. 13-17; Guo et al. 2023, Eq. 8) is evaluated from turbgen.theory, not from the
generator's stencil, so the validator checks the generator's factorisation too. The cells around the k1 axis are
integrated with turbgen.theory.lattice.cell_rule graded and sized differently from turbgen.synthesis.mann_cells,
so an error in either shows up as a disagreement: keep the parameters distinct."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from turbgen.grid import Grid
from turbgen.theory.eddy_lifetime import evolution_lifetime_s
from turbgen.theory.lattice import cell_rule, gauss_panel, k2_wavenumbers, k3_wavenumbers
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import MannParams
from turbgen.validation.store_run import MannBox

CELL_RADIUS = 2  # cells |k2| <= 2 dk2, |k3| <= 2 dk3 around the k1 axis are integrated, not point-sampled
CELL_K1_MAX = 8.0  # ... for |k1| <= 8 max(dk2, dk3); beyond, Phi is smooth on the cell scale there
CELL_GAUSS = 4


@lru_cache(maxsize=64)
def _cell_nodes(n1: int, n2: tuple, n3: tuple):
    """Indices into the x1 rule and the concatenated x2 and x3 rules listing the nodes cell by cell, (x1, x2, x3)
    C order within each, and each cell's first node (the cells' rule sizes repeat from k1 to k1: cached)."""
    o2, o3 = np.cumsum((0, *n2)), np.cumsum((0, *n3))
    cells = [np.meshgrid(np.arange(n1), np.arange(o2[j], o2[j + 1]), np.arange(o3[m], o3[m + 1]), indexing="ij")
             for j in range(len(n2)) for m in range(len(n3))]
    i1, i2, i3 = (np.concatenate([c[a].ravel() for c in cells]) for a in range(3))
    return i1, i2, i3, np.cumsum([0, *(c[0].size for c in cells[:-1])])


class MannLattice:
    """Mann tensor and space-time decay on the (k2, k3) lattice of the box, slab by slab in k1; each point stands for
    Phi(k) dk1 dk2 dk3, but near the k1 axis at small k1 the cell integral is computed (Mann 1998). ``grid``: the
    store's (dt [s], dy, dz [m]); ``U`` [m/s]: k1 = 2 pi f / U."""

    def __init__(self, params: MannParams, grid: Grid, box: MannBox, U: float):
        self.params, self.grid, self.box, self.U = params, grid, box, U
        # (k2, k3) lattice [rad/m], (nyp, nzp) each, FFT order (k2 Nyquist positive, as synthesised)
        self.k2, self.k3 = np.meshgrid(
            k2_wavenumbers(box.nyp, grid.dy_m), k3_wavenumbers(box.nzp, grid.dz_m), indexing="ij"
        )
        self.dk1 = dk1 = 2 * np.pi / (grid.nt * grid.dt_s * U)
        self.dk2, self.dk3 = 2 * np.pi / (box.nyp * grid.dy_m), 2 * np.pi / (box.nzp * grid.dz_m)
        self.dk = dk1 * self.dk2 * self.dk3
        self.r2 = min(CELL_RADIUS, (box.nyp - 1) // 2)
        self.r3 = min(CELL_RADIUS, (box.nzp - 1) // 2)

    def _axis_cells(self, k1: float) -> np.ndarray:
        """∫_cell Phi dk over the (2 r2 + 1) x (2 r3 + 1) cells around the axis at k1, (3, 3, 2r2+1, 2r3+1)."""
        x1, w1 = gauss_panel(k1 - self.dk1 / 2, k1 + self.dk1 / 2, 2)
        scale = max(abs(k1), self.dk1 / 4)
        rules2 = [cell_rule(j * self.dk2, self.dk2, CELL_GAUSS, scale, 2.0, 40) for j in range(-self.r2, self.r2 + 1)]
        rules3 = [cell_rule(l * self.dk3, self.dk3, CELL_GAUSS, scale, 2.0, 40) for l in range(-self.r3, self.r3 + 1)]
        (x2, w2), (x3, w3) = ([np.concatenate(a) for a in zip(*r)] for r in (rules2, rules3))
        i1, i2, i3, starts = _cell_nodes(x1.size, tuple(x.size for x, _ in rules2), tuple(x.size for x, _ in rules3))
        phi = sheared_tensor(x1[i1], x2[i2], x3[i3], self.params) * (w1[i1] * w2[i2] * w3[i3])  # all cells at once
        cells = np.add.reduceat(phi, starts, axis=2)
        return cells.reshape(3, 3, len(rules2), len(rules3))

    def slabs(self, k1: np.ndarray, batch: int = 8):
        """Yield (index, Phi (3, 3, nyp, nzp) times dk1 dk2 dk3 (cell integrals), 1/tau_e (nyp, nzp) [1/s]) per k1."""
        iy = np.arange(-self.r2, self.r2 + 1) % self.box.nyp
        iz = np.arange(-self.r3, self.r3 + 1) % self.box.nzp
        k1_cells = CELL_K1_MAX * max(self.dk2, self.dk3)
        for i0 in range(0, k1.size, batch):
            kk = k1[i0 : i0 + batch][:, None, None]
            # the generator's slab of time frequency f holds k1 = -2 pi f / U (time reversal, see
            # synthesis.mann_stencil); Phi(-k1, k2, k3) differs from Phi(k1, k2, k3) on the unpaired Nyquist rows
            phi = sheared_tensor(-kk, self.k2[None], self.k3[None], self.params) * self.dk
            kmag = np.sqrt(kk * kk + self.k2[None] ** 2 + self.k3[None] ** 2)
            with np.errstate(divide="ignore"):
                inv_tau = 1.0 / evolution_lifetime_s(kmag, self.params)  # Eq. 15 (0 when frozen)
            for n in range(kk.shape[0]):
                p = phi[:, :, n]
                k1n = float(kk[n, 0, 0])
                if k1n <= k1_cells:
                    cells = self._axis_cells(-k1n)
                    if k1n == 0.0:
                        cells[:, :, self.r2, self.r3] = 0.0  # the box mean (k = 0) carries no energy
                    p[:, :, iy[:, None], iz[None, :]] = cells
                yield i0 + n, p, inv_tau[n]

