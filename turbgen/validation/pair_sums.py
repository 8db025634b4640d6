"""Sums over the pairs of points of the grid, by lag: the correlation sums rho_bar of averaged estimates.

All sums run over the (2 ny - 1, 2 nz - 1) grid of lags (dy, dz) between two points of one plane: a coherence times
the number of point pairs of a set at that lag. For Gaussian fields Cov(|X_p|^2, |X_q|^2) = E|X_p|^2 E|X_q|^2
coh2_pq (Isserlis 1918), so an average over N points has the one-point variance times rho_bar = sum_pq coh2_pq /
N^2. The sums are kept at pairs of frequency nodes, R(nu_i, nu_j) = sum_pq coh_pq(nu_i) conj(coh_pq(nu_j)) / N^2,
as the exact Welch covariance needs (``welch_variance``); rho_bar(nu) = R(nu, nu)."""

from __future__ import annotations

import numpy as np

from turbgen import fft
from turbgen.grid import Grid
from turbgen.validation.estimators import COMPONENTS
from turbgen.validation.prediction import SamplingDesign, dx_key

def rect_pair_counts(ny: int, nz: int, my: int, mz: int) -> np.ndarray:
    """(2 ny - 1, 2 nz - 1) number of ordered pairs of points of an my x mz rectangle of grid points per lag (float)."""
    dy = np.arange(-(ny - 1), ny)
    dz = np.arange(-(nz - 1), nz)
    return np.maximum(my - np.abs(dy), 0)[:, None] * np.maximum(mz - np.abs(dz), 0)[None, :].astype(float)


def set_pair_counts(ny: int, nz: int, iy: np.ndarray, iz: np.ndarray) -> np.ndarray:
    """Pairs of points of the sub-lattice ``iy`` x ``iz`` (grid indices) per lag, as :func:`rect_pair_counts`."""
    cy = np.zeros(2 * ny - 1)
    cz = np.zeros(2 * nz - 1)
    np.add.at(cy, (iy[:, None] - iy[None, :]).ravel() + ny - 1, 1.0)
    np.add.at(cz, (iz[:, None] - iz[None, :]).ravel() + nz - 1, 1.0)
    return cy[:, None] * cz[None, :]


def lag_radius(grid: Grid) -> np.ndarray:
    """|r| [m] on the (2ny-1, 2nz-1) lag grid."""
    dy = np.arange(-(grid.ny - 1), grid.ny) * grid.dy_m
    dz = np.arange(-(grid.nz - 1), grid.nz) * grid.dz_m
    return np.hypot(dy[:, None], dz[None, :])


class RhoAccumulator:
    """Two-frequency sums R (nn, nn) over all ordered pairs of every averaged point set of ``design`` at ``nn``
    frequency nodes; the u-w sum ``uw`` (nn,) is one-frequency (|coherency|^2)."""

    def __init__(self, design: SamplingDesign, nn: int):
        grid, seps, iy, iz = design.grid, design.separations, design.long_iy, design.long_iz
        self.grid, self.seps = grid, seps
        ny, nz, nx = grid.ny, grid.nz, grid.nx
        self.counts_all = rect_pair_counts(ny, nz, ny, nz)
        self.counts_yz = {s: rect_pair_counts(ny, nz, ny - s[0], nz - s[1]) for s in seps}
        self.counts_long = set_pair_counts(ny, nz, iy, iz)
        self.norm_all = (nx * ny * nz) ** 2
        self.norm_yz = {s: (nx * (ny - s[0]) * (nz - s[1])) ** 2 for s in seps}
        self.norm_long = (iy.size * iz.size) ** 2
        self.all = {c: np.zeros((nn, nn)) for c in COMPONENTS}
        self.yz = {c: {s: np.zeros((nn, nn)) for s in seps} for c in COMPONENTS}
        self.long = np.zeros((nn, nn))
        self.uw = np.zeros(nn)

    def add(self, component: str, coh: np.ndarray, multiplicity: int, same_plane: bool) -> None:
        """Add the coherency ``coh`` (nodes, 2ny-1, 2nz-1) [-] between the points of two planes, for ``multiplicity``
        ordered plane pairs with this separation."""
        half = half_lags(coh)  # the real and imaginary parts once for all the point sets
        self.all[component] += multiplicity * weighted_gram(half, self.counts_all) / self.norm_all
        for s in self.seps:
            self.yz[component][s] += multiplicity * weighted_gram(half, self.counts_yz[s]) / self.norm_yz[s]
        if same_plane and component == "u":
            self.long += weighted_gram(half, self.counts_long) / self.norm_long

    def add_uw(self, coh2: np.ndarray, multiplicity: int) -> None:
        """|u-w coherency|^2 (all nodes, 2ny-1, 2nz-1) between points of two planes, as :meth:`add`."""
        self.uw += multiplicity * np.einsum("nij,ij->n", coh2, self.counts_all) / self.norm_all


def half_lags(coh: np.ndarray) -> np.ndarray:
    """The centre and one half of the (point-symmetric) lag grid of ``coh`` (nn, 2 ny - 1, 2 nz - 1), flat from lag 0
    on: (nn, H) if real, [Re | Im] (nn, 2 H) if complex (:func:`weighted_gram`)."""
    flat = coh.reshape(coh.shape[0], -1)
    half = flat[:, (flat.shape[1] - 1) // 2 :]
    return np.concatenate([half.real, half.imag], axis=1) if np.iscomplexobj(half) else np.ascontiguousarray(half)


def weighted_gram(half: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """(nn, nn) real sum over lags of counts x coh(nu_i) conj(coh(nu_j)), one symmetric product over half the lags."""
    w = counts.ravel()[(counts.size - 1) // 2 :] * 2.0
    w[0] *= 0.5  # lag 0 is its own mirror
    sw = np.sqrt(w)
    a = half * (np.tile(sw, 2) if half.shape[1] > sw.size else sw)
    return a @ a.T  # numpy recognises a @ a.T (syrk): exactly symmetric


def rotor_pair_counts(grid: Grid, mask: np.ndarray) -> np.ndarray:
    """Pairs of rotor points (``mask``, (ny, nz) bool) per lag, as :func:`rect_pair_counts` (mask autocorrelation)."""
    sy, sz = 2 * grid.ny - 1, 2 * grid.nz - 1
    f = fft.oneshot().rfft2(mask.astype(float), s=(sy, sz))
    ac = fft.oneshot().irfft2(np.abs(f) ** 2, s=(sy, sz))
    return np.round(fft.fftshift(ac, axes=(0, 1)))


def box_lags(field2d: np.ndarray, ny: int, nz: int) -> np.ndarray:
    """Values of a periodic box field (..., nyp, nzp) at the grid's lags -(n-1) .. n-1 -> (..., 2 ny - 1, 2 nz - 1)."""
    iy = np.arange(-(ny - 1), ny) % field2d.shape[-2]
    iz = np.arange(-(nz - 1), nz) % field2d.shape[-1]
    return field2d[..., iy[:, None], iz[None, :]]


def real_box_lags(field2d: np.ndarray, ny: int, nz: int) -> np.ndarray:
    """``box_lags(ifft2(field2d) * size, ny, nz)`` for a real field (..., nyp, nzp) with half the transform."""
    nyp, nzp = field2d.shape[-2:]
    if nzp < 2 * nz - 1:
        return box_lags(fft.oneshot().ifft2(field2d) * (nyp * nzp), ny, nz)
    half = np.conj(fft.oneshot().rfft2(field2d, workers=1))  # (..., nyp, nzp // 2 + 1): dz = 0 .. nzp / 2
    rows = np.concatenate([half[..., nyp - ny + 1 :, :nz], half[..., :ny, :nz]], axis=-2)  # dy = -(ny - 1) .. ny - 1
    neg = np.conj(rows[..., ::-1, :0:-1])  # dz = -(nz - 1) .. -1: F(dy, -m) = conj(F(-dy, m))
    return np.concatenate([neg, rows], axis=-1)


def coherency_matrix(lags: dict, grid: Grid) -> np.ndarray:
    """(nx ny nz, nx ny nz) coherency [-] between all points of all planes (ordered by plane, y, z)."""
    iy, iz = (a.ravel() for a in np.meshgrid(np.arange(grid.ny), np.arange(grid.nz), indexing="ij"))
    dy = iy[:, None] - iy[None, :] + grid.ny - 1
    dz = iz[:, None] - iz[None, :] + grid.nz - 1
    return np.block([[lags[dx_key(xp - xq)][dy, dz] for xq in grid.x_m] for xp in grid.x_m])
