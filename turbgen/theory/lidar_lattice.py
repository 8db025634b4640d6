"""The (k2, k3) quadrature of a periodic synthesis box, for the lidar preview spectra of what the box holds.

A Mann field synthesised on a periodic box of nyp x nzp points spaced dy, dz [m] holds Phi on the lattice
k2 = j dk2, k3 = l dk3 only (Mann 1998, Sec. 2; turbgen.theory.lattice), missing the lateral wavenumbers below
dk2 = 2 pi / (nyp dy), dk3 = 2 pi / (nzp dz), which shape the lidar-rotor coherence at k1 ~ dk2, dk3 (Guo et al. 2023,
Eq. 24, 29, 32); the lattice sum (the box field's expectation) converges to the continuous integral as the box grows.

Each lattice point carries Phi(k) dk2 dk3, except near the k1 axis at small |k1|, where Phi varies strongly within a
cell: there the cell average over [k1 - dk1/2, k1 + dk1/2] (dk1 = 2 pi / (U T)). The grading (CELL_RADIUS,
CELL_K1_FACTOR, CELL_GAUSS, GRADING) is this module's own, distinct from the generator's and the validator's, so an
error in any of them shows."""

from __future__ import annotations

from dataclasses import dataclass
import numpy as np

from turbgen.errors import check_int, check_positive
from turbgen.theory.lattice import cell_rule, gauss_panel, k2_wavenumbers, k3_wavenumbers
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import MannParams

CELL_RADIUS = 3  # cells |k2| <= 3 dk2, |k3| <= 3 dk3 around the k1 axis are integrated ...
CELL_K1_FACTOR = 6.0  # ... for |k1| <= 6 max(dk2, dk3)
CELL_GAUSS = 6  # Gauss-Legendre nodes per panel (k2, k3); 3 in k1
GRADING = 3.0  # panels of the axis cell shrink by this factor towards k2 = 0 (k3 = 0), down to |k1| / GRADING


@dataclass(frozen=True)
class BoxLattice:
    """The periodic synthesis box whose (k2, k3) lattice replaces the continuous quadrature: points of the padded box
    in y and z and their spacings [m], and the record's length nt dt [s] (axis cells' k1 width 2 pi / (U T))."""

    nyp: int
    nzp: int
    dy_m: float
    dz_m: float
    record_s: float

    def __post_init__(self):
        check_int("box points in y", self.nyp, 2)
        check_int("box points in z", self.nzp, 2)
        check_positive("box dy (m)", self.dy_m)
        check_positive("box dz (m)", self.dz_m)
        check_positive("record length (s)", self.record_s)

    def spacings(self) -> tuple[float, float]:
        """(dk2, dk3) = (2 pi / (nyp dy), 2 pi / (nzp dz)) [rad/m]."""
        return 2 * np.pi / (self.nyp * self.dy_m), 2 * np.pi / (self.nzp * self.dz_m)


def _axis_cells(k1: float, dk1: float, dk2: float, dk3: float, r2: int, r3: int, params: MannParams):
    """(1/dk1) ∫_cell Phi dk over the (2 r2 + 1) x (2 r3 + 1) cells around the axis at k1: (3, 3, 2r2+1, 2r3+1)."""
    x1, w1 = gauss_panel(k1 - dk1 / 2, k1 + dk1 / 2, 3)
    scale = max(abs(k1), dk1 / 4) / GRADING
    rules2 = [cell_rule(j * dk2, dk2, CELL_GAUSS, scale, GRADING, 60) for j in range(-r2, r2 + 1)]
    rules3 = [cell_rule(l * dk3, dk3, CELL_GAUSS, scale, GRADING, 60) for l in range(-r3, r3 + 1)]
    x2, w2 = np.concatenate([r[0] for r in rules2]), np.concatenate([r[1] for r in rules2])
    x3, w3 = np.concatenate([r[0] for r in rules3]), np.concatenate([r[1] for r in rules3])
    c2 = np.repeat(np.arange(len(rules2)), [r[0].size for r in rules2])
    c3 = np.repeat(np.arange(len(rules3)), [r[0].size for r in rules3])
    k1n, k2n, k3n = np.meshgrid(x1, x2, x3, indexing="ij")
    weight = w1[:, None, None] * w2[None, :, None] * w3[None, None, :] / dk1
    phi = sheared_tensor(k1n, k2n, k3n, params) * weight  # (3, 3, n1, n2, n3)
    phi = phi.sum(axis=2)
    out = np.zeros((3, 3, len(rules2), len(rules3)))
    np.add.at(out, (slice(None), slice(None), c2[:, None], c3[None, :]), phi)
    return out


def lattice_wavenumbers(box: BoxLattice) -> tuple[np.ndarray, np.ndarray]:
    """The box's lattice k2, k3 [rad/m], each (nyp nzp,), row-major over the FFT orders of turbgen.theory.lattice."""
    k2, k3 = np.meshgrid(k2_wavenumbers(box.nyp, box.dy_m), k3_wavenumbers(box.nzp, box.dz_m), indexing="ij")
    return k2.ravel(), k3.ravel()


def lattice_tensor(box: BoxLattice, k1: float, params: MannParams, U_m_s: float):
    """Phi dk2 dk3 [m^3 s^-2], (3, 3, nyp nzp), on the box's lattice at k1 [rad/m], the axis cells integrated; at the
    nodes of :func:`lattice_wavenumbers`, a density in k1 like Phi; ``U_m_s`` [m/s] sets the record's line spacing
    dk1 = 2 pi / (U T) (module docstring)."""
    dk2, dk3 = box.spacings()
    k2, k3 = (k.reshape(box.nyp, box.nzp) for k in lattice_wavenumbers(box))
    phi = sheared_tensor(k1, k2, k3, params) * (dk2 * dk3)  # (3, 3, nyp, nzp)
    if abs(k1) <= CELL_K1_FACTOR * max(dk2, dk3):
        r2, r3 = min(CELL_RADIUS, (box.nyp - 1) // 2), min(CELL_RADIUS, (box.nzp - 1) // 2)
        iy = np.arange(-r2, r2 + 1) % box.nyp
        iz = np.arange(-r3, r3 + 1) % box.nzp
        phi[:, :, iy[:, None], iz[None, :]] = _axis_cells(k1, 2 * np.pi / (U_m_s * box.record_s), dk2, dk3, r2, r3,
                                                          params)
    return phi.reshape(3, 3, -1)
