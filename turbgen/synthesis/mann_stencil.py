"""The Mann (1998) synthesis stencil of one parameter set and grid: C(k) and 1/tau_e(k), stored compactly.

The box is (xi, y, z) with xi along the mean wind; the real FFT is taken along xi (= the time
axis of a plane, dx = U dt), so the half spectrum holds slabs k1 >= 0 of shape (nyp, nzp).
Time reversal: a plane sees the frozen box u(xi = -U t) (Taylor: u(X, T) = u_box(X - U T)), so
the stored slab of FFT frequency index i holds the physical wavenumber k1 = -i dk1.

Compact factor. With a = sqrt(E(k0)/(4 pi))/k0^2, m = k2 n0 - k1 n1 and C = D A (Mann 1998
Eq. 46-47; turbgen.theory.mann_tensor.tensor_factor) the product u_hat = C n reads
    u_hat_u = P n1 - (A k2) n2 + Z1 m,   u_hat_v = -P n0 + (A k1) n2 + Z2 m,   u_hat_w = W m
with A = a, P = a k30, Z1 = a zeta1, Z2 = a zeta2, all times sqrt(dk1 dk2 dk3 / 2) (the noise has
E|n|^2 = 2), and W = a k0^2/k^2 = (A^2 q + P^2) / (A k^2), q = k1^2 + k2^2, rebuilt when used
(k0^2 = q + k30^2, k30 = P/A). Under k2 -> -k2 the coefficients A, P, Z1 are even and Z2 is odd,
so only rows k2 >= 0 are stored: 4 float32 numbers per (k1 >= 0, k2 >= 0, k3), i.e. 1/4 of the
full 8-entry float32 factor on the whole half spectrum.
"""

from __future__ import annotations

import hashlib
import json
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np

from turbgen.theory.eddy_lifetime import evolution_lifetime_table, shear_lifetime_table
from turbgen.theory.lattice import k2_wavenumbers, k3_wavenumbers
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import MannParams

STENCIL_VERSION = 4  # 3: lifetimes from tables, coefficients straight from Mann (1994) Eq. 13-17; 4: arctan
_ODD = (False, False, False, True)  # parity of A, P, Z1, Z2 under k2 -> -k2
_BUILD_POINTS = 1 << 16  # points per float64 batch and thread while building (0.5 MiB per temporary)
# Cell-averaged tensor near the k1 axis (Mann 1998: the point value Phi(k) dk is a poor estimate of
# the cell integral where Phi varies within a cell). On the k1 axis Phi33 = E(k0) / (4 pi k1^2) with
# k0 -> Gamma a / L finite, so with dk1 << dk2, dk3 (long boxes) the point rule puts far too much
# energy in the cells (k1, 0, 0): sigma_w^2 of the default paper box came out 76 % above the model.
# Cells with |k2| <= CELL_RADIUS dk2, |k3| <= CELL_RADIUS dk3 and |k1| <= CELL_K1_FACTOR max(dk2, dk3)
# use a square root of the cell-averaged tensor instead (tensor-product Gauss rules, graded towards
# the k1 axis down to the scale |k1|). turbgen.validate.mann_lattice integrates these cells with its own
# rule on purpose (an independent check of this one): do not share the rules.
CELL_RADIUS = 2
CELL_K1_FACTOR = 4.0  # (1, 2) and (3, 8) change the paper box's sigma^2 by < 0.4 % and < 0.1 %
_CELL_GAUSS = 4


@dataclass(frozen=True)
class BoxShape:
    """The synthesis box: nt samples along xi spaced dx_m [m], nyp x nzp (padded) spaced dy_m, dz_m [m]."""

    nt: int
    dx_m: float
    nyp: int
    nzp: int
    dy_m: float
    dz_m: float

    @property
    def nk1(self) -> int:
        """Slabs of the real-FFT half spectrum along xi."""
        return self.nt // 2 + 1

    @property
    def nk2_half(self) -> int:
        """Stored k2 rows (k2 = 0 .. nyp//2)."""
        return self.nyp // 2 + 1

    def dk(self) -> tuple[float, float, float]:
        """Wavenumber spacings (dk1, dk2, dk3) [rad/m] of the periodic box."""
        return (
            2 * np.pi / (self.nt * self.dx_m),
            2 * np.pi / (self.nyp * self.dy_m),
            2 * np.pi / (self.nzp * self.dz_m),
        )

    def k1(self) -> np.ndarray:
        """Physical k1 [rad/m] of the stored slabs: -i dk1 (time reversal, see module docstring)."""
        return -np.arange(self.nk1) * self.dk()[0]

    def k2(self) -> np.ndarray:
        """k2 [rad/m] of all nyp rows: j dk2 for j <= nyp//2 (Nyquist stored positive), else (j - nyp) dk2."""
        return k2_wavenumbers(self.nyp, self.dy_m)

    def k3(self) -> np.ndarray:
        """k3 [rad/m] of the nzp columns (numpy fftfreq order)."""
        return k3_wavenumbers(self.nzp, self.dz_m)


@dataclass(frozen=True, eq=False)
class MannStencil:
    """Compact factor ``coef`` (4, nk1, nyp//2+1, nzp) float32 (A, P, Z1, Z2), ``inv_tau`` = 1/tau_e [1/s] (None if
    frozen or built with evolving=False: then it serves single snapshots only),
    and the cell-averaged factors near the k1 axis: ``cell_index`` (ncell, 3) int (slab, row, column),
    sorted by slab, and ``cell_factor`` (ncell, 3, 3) float32 (times sqrt(dk1 dk2 dk3 / 2)), which
    replace the compact factor at those points."""

    params: MannParams
    box: BoxShape
    coef: np.ndarray
    inv_tau: np.ndarray | None
    cell_index: np.ndarray
    cell_factor: np.ndarray
    slab0: int = 0  # coef / inv_tau hold slabs slab0 .. slab0 + coef.shape[1] (a part of the box: out-of-core runs)

    @property
    def slab_range(self) -> tuple[int, int]:
        """Slabs [first, end) that coef and inv_tau hold."""
        return self.slab0, self.slab0 + self.coef.shape[1]

    def cells_in(self, i0: int, i1: int) -> slice:
        """Rows of cell_index / cell_factor whose slab lies in [i0, i1)."""
        slabs = self.cell_index[:, 0]
        return slice(int(np.searchsorted(slabs, i0)), int(np.searchsorted(slabs, i1)))


def stencil_nbytes(box: BoxShape, with_tau: bool) -> int:
    """Bytes held by the stencil of ``box`` (for memory estimates before building it)."""
    per = box.nk1 * box.nk2_half * box.nzp * 4
    return per * (5 if with_tau else 4)


def expand_k2(half: np.ndarray, nyp: int, odd: bool, out: np.ndarray) -> np.ndarray:
    """Rows k2 >= 0 (..., nyp//2+1, nz) -> all nyp rows in FFT order, negated on k2 < 0 if ``odd``."""
    h = nyp // 2
    out[..., : h + 1, :] = half
    mirror = half[..., nyp - h - 1 : 0 : -1, :]  # row j > h is row nyp - j of the k2 >= 0 half
    if odd:
        np.negative(mirror, out=out[..., h + 1 :, :])
    else:
        out[..., h + 1 :, :] = mirror
    return out


def w_coefficient(a, p, q, ksq, out, scratch):
    """W = a k0^2 / k^2 = (A^2 q + P^2) / (A k^2) into ``out`` (0 where A k^2 = 0: there m = 0).

    ``q`` = k1^2 + k2^2 and ``ksq`` = |k|^2 broadcast against ``a``; ``scratch`` like ``out``.
    """
    np.multiply(a, a, out=out)
    out *= q
    np.multiply(p, p, out=scratch)
    out += scratch
    np.multiply(a, ksq, out=scratch)
    np.divide(out, scratch, out=out, where=scratch != 0)
    out[scratch == 0] = 0
    return out


def _coefficients(params: MannParams, k1, k2, k3, out: np.ndarray, inv_tau: np.ndarray | None) -> None:
    """(A, P, Z1, Z2) of slabs k1 (b, 1, 1) on rows k2 (nh, 1) x columns k3 (nzp,) into ``out`` (4, b, nh, nzp).

    Straight from Mann (1994) Eq. 13-17 (the formulas of theory.mann_tensor._distortion with its
    exact limits), in float64, with beta = Gamma tau~(|k| L) and tau_e from the lifetime tables
    (relative error <= 1e-6, theory.eddy_lifetime.TABLE_REL_ERROR) instead of Eq. 4 / 6 / 15 point
    by point. a = sqrt(E(k0) / (4 pi)) / k0^2 = sqrt(ae L^(17/3) / (4 pi)) (1 + (k0 L)^2)^(-17/12).
    ``out`` holds the coefficients without the sqrt(dk / 2) scale; ``inv_tau`` (b, nh, nzp) gets 1/tau_e.
    """
    L = params.length_scale_m
    q = k1 * k1 + k2 * k2  # (b, nh, 1)
    ksq = q + k3 * k3  # (b, nh, nzp)
    a, p, z1, z2 = out
    if params.gamma == 0.0:
        beta = np.zeros_like(ksq)
    else:
        beta = shear_lifetime_table(params).from_ksq(ksq, L)
        beta *= params.gamma
    with np.errstate(invalid="ignore"):
        bk1 = beta * k1  # nan at k = 0 (inf * 0): set to 0 below
    k30 = np.add(bk1, k3, out=p)  # P = a k30 once a is known
    k0sq = k30 * k30
    k0sq += q
    np.multiply(k0sq, L * L, out=a)
    a += 1.0
    np.log(a, out=a)
    a *= -17.0 / 12.0
    np.exp(a, out=a)
    a *= np.sqrt(params.ae * L ** (17.0 / 3.0) / (4.0 * np.pi))
    with np.errstate(divide="ignore", invalid="ignore"):
        sq = np.sqrt(q)
        c1 = np.multiply(bk1, k30, out=z1)
        c1 -= 2.0 * k30 * k30
        c1 += k0sq
        c1 *= bk1 * k1
        c1 /= ksq * q
        # atan2(Y, X) with Y = beta k1 sqrt(q) <= 0 (stored k1 <= 0, beta >= 0): arctan(Y / X), minus pi where
        # X < 0 (the continuous branch of Mann 1994 Eq. 16; twice as fast as np.arctan2 here)
        x = k0sq - k30 * bk1
        c2 = np.arctan(np.divide(bk1 * sq, x, out=z2), out=z2)
        c2 -= np.pi * (x < 0)
        c2 *= k0sq
        c2 *= k2 / (q * sq)
        ratio = k2 / k1
        c1_ratio = c1 * ratio
        c1 -= c2 * ratio  # zeta1 = C1 - (k2/k1) C2
        c2 += c1_ratio  # zeta2 = (k2/k1) C1 + C2
    p *= a
    z1 *= a
    z2 *= a
    for i in np.flatnonzero(k1[:, 0, 0] == 0.0):  # the k1 -> 0 limit at fixed q > 0: zeta1 = -beta, zeta2 = 0
        np.multiply(beta[i], a[i], out=z1[i])
        np.negative(z1[i], out=z1[i])
        z2[i] = 0.0
        axis = q[i, :, 0] == 0  # the row k2 = 0 is the k3 axis: zeta = 0, and A is never used (m = 0, k2 = 0)
        z1[i, axis] = 0.0
        a[i, axis] = 0.0
        p[i] = np.where(ksq[i] == 0, 0.0, p[i])  # k = 0 (beta = inf there) carries no energy
    if inv_tau is not None:
        tau = evolution_lifetime_table(params).from_ksq(ksq, L)
        tau *= params.evo_time_s  # tau_e [s], paper 000 Eq. 15 (inf at k = 0)
        np.divide(1.0, tau, out=inv_tau)


def build_step(box: BoxShape) -> int:
    """Slabs per stencil-building batch: batches start at multiples of it (also when building a part)."""
    return max(1, _BUILD_POINTS // (box.nk2_half * box.nzp))


def _build(params: MannParams, box: BoxShape, with_tau: bool, slabs=None, cells=None) -> MannStencil:
    first, end = (0, box.nk1) if slabs is None else slabs
    nh, nzp = box.nk2_half, box.nzp
    scale = np.sqrt(np.prod(box.dk()) / 2.0)
    k1_all = box.k1()
    k2 = box.k2()[:nh][:, None]
    k3 = box.k3()
    coef = np.empty((4, end - first, nh, nzp), dtype=np.float32)
    inv_tau = np.empty((end - first, nh, nzp), dtype=np.float32) if with_tau else None
    step = build_step(box)

    def batch(i0: int) -> None:  # independent slab batches: threads only change who computes which
        i1 = min((i0 // step + 1) * step, end)  # the batches of the whole stencil, cut to [first, end)
        work = np.empty((4, i1 - i0, nh, nzp))
        tau = np.empty((i1 - i0, nh, nzp)) if with_tau else None
        _coefficients(params, k1_all[i0:i1, None, None], k2, k3, work, tau)
        work *= scale
        coef[:, i0 - first : i1 - first] = work
        if with_tau:
            inv_tau[i0 - first : i1 - first] = tau

    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        list(pool.map(batch, [first, *range((first // step + 1) * step, end, step)]))
    index, factor = _axis_cells(params, box) if cells is None else cells
    return MannStencil(params, box, coef, inv_tau, index, factor, first)


@lru_cache(maxsize=4)
def _unit_gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.polynomial.legendre.leggauss(n)


def _gauss_rule(a: float, b: float, n: int = _CELL_GAUSS) -> tuple[np.ndarray, np.ndarray]:
    x, w = _unit_gauss(n)
    return 0.5 * (b - a) * x + 0.5 * (a + b), 0.5 * (b - a) * w


def _cell_rule(center: float, width: float, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes/weights over [center - width/2, center + width/2]; graded towards 0 (down to ``scale``) if center = 0."""
    if center != 0.0:
        return _gauss_rule(center - width / 2, center + width / 2)
    edges = [width / 2]
    while edges[-1] > 2 * scale and len(edges) < 30:
        edges.append(edges[-1] / 2)
    edges = np.array([0.0, *edges[::-1]])
    parts = [_gauss_rule(a, b) for a, b in zip(edges[:-1], edges[1:])]
    x = np.concatenate([p[0] for p in parts])
    w = np.concatenate([p[1] for p in parts])
    return np.concatenate([-x[::-1], x]), np.concatenate([w[::-1], w])


def _axis_cells(params: MannParams, box: BoxShape) -> tuple[np.ndarray, np.ndarray]:
    """Cell-averaged factors (see CELL_RADIUS): Phi_bar = (1/dV) ∫_cell Phi dk, factor V sqrt(Lambda).

    All cells of one slab are evaluated in one call: the nodes of all (k2, k3) cells are one outer product
    of the k1 rule with the concatenated k2 and k3 rules, summed per cell by np.bincount. beta comes from
    the lifetime table (as in the rest of the stencil).
    """
    dk1, dk2, dk3 = box.dk()
    r2 = min(CELL_RADIUS, (box.nyp - 1) // 2)
    r3 = min(CELL_RADIUS, (box.nzp - 1) // 2)
    n_slabs = min(box.nk1, int(CELL_K1_FACTOR * max(dk2, dk3) / dk1) + 1)
    table = shear_lifetime_table(params)
    js, ls = np.arange(-r2, r2 + 1), np.arange(-r3, r3 + 1)
    n3 = len(ls)
    index, factor = [], []
    for i in range(n_slabs):
        k1c = box.k1()[i]
        x1, w1 = _gauss_rule(k1c - dk1 / 2, k1c + dk1 / 2, 2)
        scale = max(abs(k1c), dk1 / 4)
        rules2 = [_cell_rule(j * dk2, dk2, scale) for j in js]
        rules3 = [_cell_rule(l * dk3, dk3, scale) for l in ls]
        x2, w2 = np.concatenate([r[0] for r in rules2]), np.concatenate([r[1] for r in rules2])
        x3, w3 = np.concatenate([r[0] for r in rules3]), np.concatenate([r[1] for r in rules3])
        id2 = np.repeat(np.arange(len(js)), [len(r[0]) for r in rules2])
        id3 = np.repeat(np.arange(n3), [len(r[0]) for r in rules3])
        shape = (len(x1), len(x2), len(x3))
        k1n, k2n, k3n = (np.broadcast_to(v, shape).ravel() for v in (x1[:, None, None], x2[None, :, None], x3))
        weight = (w1[:, None, None] * w2[None, :, None] * w3[None, None, :]).ravel()
        cell = np.broadcast_to(id2[None, :, None] * n3 + id3[None, None, :], shape).ravel()
        beta = params.gamma * table.from_ksq(k1n * k1n + k2n * k2n + k3n * k3n, params.length_scale_m)
        phi = sheared_tensor(k1n, k2n, k3n, params, beta=beta) * weight
        ncell = len(js) * n3
        cells = np.stack(  # ∫_cell Phi dk / 2 (E|n|^2 = 2), (3, 3, ncell)
            [[np.bincount(cell, phi[a, b], minlength=ncell) for b in range(3)] for a in range(3)]
        ) / 2.0
        if i == 0:
            cells[:, :, r2 * n3 + r3] = 0.0  # the cell around k = 0: the box mean stays zero
        lam, vec = np.linalg.eigh(np.moveaxis(cells, -1, 0))
        factor.append(vec * np.sqrt(np.clip(lam, 0.0, None))[:, None, :])
        index.extend((i, j % box.nyp, l % box.nzp) for j in js for l in ls)
    index = np.array(index, dtype=np.int64).reshape(-1, 3)
    factor = np.concatenate(factor).astype(np.float32) if factor else np.zeros((0, 3, 3), np.float32)
    return index, factor


def stencil_key(params: MannParams, box: BoxShape, with_tau: bool) -> str:
    """Hash of everything the stencil depends on (cache file name)."""
    text = json.dumps(
        {"v": STENCIL_VERSION, "params": asdict(params), "box": asdict(box), "tau": with_tau}, sort_keys=True
    )
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def build_stencil(
    params: MannParams, box: BoxShape, *, evolving: bool = True, slabs: tuple[int, int] | None = None, cells=None
) -> MannStencil:
    """The stencil of ``params`` on ``box`` (computed; turbgen.runs.stencil_cache keeps it on disk).

    ``evolving=False`` skips 1/tau_e (1/6 of the memory): enough for a single snapshot (one plane).
    ``slabs=(first, end)``: only those k1 slabs (the same numbers as those slabs of the whole stencil:
    every point is computed by the same elementwise operations); ``cells``: (cell_index, cell_factor) of axis_cells, to
    compute them once for many parts.
    """
    return _build(params, box, evolving and params.evo_time_s is not None, slabs, cells)


def axis_cells(params: MannParams, box: BoxShape) -> tuple[np.ndarray, np.ndarray]:
    """(cell_index, cell_factor) of the cell-averaged factors near the k1 axis (see MannStencil)."""
    return _axis_cells(params, box)


def slab_factor(stencil: MannStencil, i: int) -> np.ndarray:
    """The full factor C (3, 3, nyp, nzp) [float64, times sqrt(dk/2)] of slab ``i``: compact form + axis cells.

    For tests and the discrete oracle: E[u_hat u_hat^H] = 2 C C^T on every stored point.
    """
    box = stencil.box
    full = [
        expand_k2(stencil.coef[n, i].astype(float), box.nyp, _ODD[n], np.empty((box.nyp, box.nzp)))
        for n in range(4)
    ]
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


def discrete_spectra(stencil: MannStencil) -> np.ndarray:
    """Exact expectation of the synthesised discrete field: S[i, j, slab] = sum over (k2, k3) of E[u_hat_i u_hat_j^*].

    Shape (3, 3, nk1), real [m^2 s^-2]. A point's variance is sum_slab w_slab S[i, i, slab] with
    w = 1 on the k1 = 0 and Nyquist slabs and 2 elsewhere (the Hermitian partner slab).
    """
    out = np.empty((3, 3, stencil.box.nk1))
    for i in range(stencil.box.nk1):
        c = slab_factor(stencil, i)
        out[:, :, i] = 2.0 * np.einsum("ikyz,jkyz->ij", c, c)
    return out

