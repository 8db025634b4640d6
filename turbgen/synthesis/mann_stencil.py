"""The Mann (1998) synthesis stencil of one parameter set and grid: C(k) and 1/tau_e(k), stored compactly.

With a = sqrt(E(k0)/(4 pi))/k0^2, m = k2 n0 - k1 n1 and C = D A (Mann 1998 Eq. 46-47) u_hat = C n reads
    u_hat_u = P n1 - (A k2) n2 + Z1 m,   u_hat_v = -P n0 + (A k1) n2 + Z2 m,   u_hat_w = W m
with A = a, P = a k30, Z1 = a zeta1, Z2 = a zeta2, times sqrt(dk1 dk2 dk3 / 2), W = (A^2 q + P^2) / (A k^2).
Z2 is odd in k2 and the rest even, so only rows k2 >= 0 are stored."""

from __future__ import annotations

import hashlib
import json
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass

import numpy as np

from turbgen.synthesis.box_shape import BoxShape
from turbgen.synthesis.mann_cells import axis_cells
from turbgen.synthesis.mann_factors import apply_energy, energy_scale, slab_factors
from turbgen.theory.params import MannParams

ENERGIES = ("scaled", "unit")
STORAGES = ("memory", "on_demand")
STENCIL_VERSION = 5  # 3: lifetime tables, Mann (1994) Eq. 13-17; 4: arctan; 5: ae-free float64 factors
_ODD = (False, False, False, True)  # parity of A, P, Z1, Z2 under k2 -> -k2
_BUILD_POINTS = 1 << 16  # points per float64 batch and thread while building (0.5 MiB per temporary)


@dataclass(frozen=True, eq=False)
class MannStencil:
    """The stencil of ``params`` on ``box`` (make it with :func:`build_stencil`); "scaled":
    ``coef`` (4, slabs, nyp//2+1, nzp) float32 (A, P, Z1, Z2) for params.ae, plus the axis cells; "unit": float64
    ae-free factors, ae = 1. ``inv_tau`` = 1/tau_e [1/s]; ``slab0`` the first slab held."""

    params: MannParams
    box: BoxShape
    coef: np.ndarray | None
    inv_tau: np.ndarray | None
    cell_index: np.ndarray | None
    cell_factor: np.ndarray | None
    slab0: int = 0
    energy: str = "scaled"

    @property
    def slab_range(self) -> tuple[int, int]:
        """Slabs [first, end) that coef and inv_tau hold (all of the box's when coef is computed on demand)."""
        return self.slab0, self.box.nk1 if self.coef is None else self.slab0 + self.coef.shape[1]

    def coefficients(self, i0: int, i1: int, scratch: np.ndarray | None = None) -> tuple[np.ndarray, int]:
        """(A, P, Z1, Z2) of slabs [i0, i1): (``coef``, or on demand ``scratch`` computed as build_stencil does, slab
        i0's index in it). ValueError for a unit stencil (scale it first)."""
        if self.energy != "scaled":
            raise ValueError("a unit stencil has no coefficients: use its scaled(params)")
        if self.coef is not None:
            return self.coef, i0 - self.slab0
        slab_factors(self.params, self.box, i0, i1, scratch[:, : i1 - i0], None, energy_scale(self.params))
        return scratch, 0

    def cells_in(self, i0: int, i1: int) -> slice:
        """Rows of cell_index / cell_factor whose slab lies in [i0, i1)."""
        slabs = self.cell_index[:, 0]
        return slice(int(np.searchsorted(slabs, i0)), int(np.searchsorted(slabs, i1)))

    def scaled(self, params: MannParams) -> "MannStencil":
        """The stencil of ``params`` (ae [m^(4/3) s^-2]) in memory, bit for bit build_stencil(params, box); ValueError
        if ``params`` differ in more than ae (scaled: at all)."""
        if self.energy == "scaled":
            if params != self.params:
                raise ValueError("the stencil was built for other parameters")
            return self
        if params.with_ae(1.0) != self.params:
            raise ValueError("the unit stencil was built for other parameters than ae")
        box, first, end = self.box, *self.slab_range
        scale = np.sqrt(np.prod(box.dk()) / 2.0)
        energy = energy_scale(params)
        k1_all = box.k1()
        coef = np.empty((4, end - first, box.nk2_half, box.nzp), dtype=np.float32)

        def batch(i0: int, i1: int) -> None:
            part = slice(i0 - first, i1 - first)
            work = np.empty((4, i1 - i0, box.nk2_half, box.nzp))
            coef[:, part] = apply_energy(self.coef[:, part], energy, k1_all[i0:i1, None, None], scale, work)

        index, factor = slab_batches(box, first, end, batch, lambda: axis_cells(params, box))
        return MannStencil(params, box, coef, self.inv_tau, index, factor, first)


def synthesis_box(run) -> BoxShape:
    """The periodic synthesis box of a Mann run (``turbgen.spec.mann.MannRun``): (nt, dx = U dt) x
    (pad_yz ny, dy) x (pad_yz nz, dz)."""
    g = run.grid
    return BoxShape(g.nt, run.U_m_s * g.dt_s, run.pad_yz * g.ny, run.pad_yz * g.nz, g.dy_m, g.dz_m)


def stencil_nbytes(box: BoxShape, with_tau: bool, energy: str = "scaled") -> int:
    """Bytes [B] of the stencil of ``box`` in memory (``energy`` "scaled" or "unit", 1/tau_e if ``with_tau``)."""
    per = box.nk1 * box.nk2_half * box.nzp
    return per * ((16 if energy == "scaled" else 32) + (4 if with_tau else 0))


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
    """W = a k0^2 / k^2 = (A^2 q + P^2) / (A k^2) into ``out`` (0 where A k^2 = 0), q = k1^2 + k2^2, ``ksq`` = |k|^2."""
    np.multiply(a, a, out=out)
    out *= q
    np.multiply(p, p, out=scratch)
    out += scratch
    np.multiply(a, ksq, out=scratch)
    np.divide(out, scratch, out=out, where=scratch != 0)
    out[scratch == 0] = 0
    return out


def build_step(box: BoxShape) -> int:
    """Slabs per stencil-building batch: batches start at multiples of it (also when building a part)."""
    return max(1, _BUILD_POINTS // (box.nk2_half * box.nzp))


def slab_batches(box: BoxShape, first: int, end: int, batch, side=None):
    """Call ``batch(i0, i1)`` on the building batches cut to [first, end) on all cores; return ``side()``, run
    alongside in the same pool (None if not given)."""
    step = build_step(box)

    def one(i0: int) -> None:  # independent slab batches: threads only change who computes which
        batch(i0, min((i0 // step + 1) * step, end))

    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        pending = None if side is None else pool.submit(side)
        list(pool.map(one, [first, *range((first // step + 1) * step, end, step)]))
        return None if pending is None else pending.result()


def _build(params: MannParams, box: BoxShape, energy: str, with_tau: bool, slabs, cells, factors) -> MannStencil:
    """A stencil stored in memory (see build_stencil): coefficients or unit factors of slabs [first, end)."""
    first, end = (0, box.nk1) if slabs is None else slabs
    shape = (4, end - first, box.nk2_half, box.nzp)
    unit = energy == "unit"
    params = params.with_ae(1.0) if unit else params
    if factors is not None and (factors.shape != shape or factors.dtype != np.float64 or not unit):
        raise ValueError(f"`factors` must be a float64 array {shape} of a unit stencil")
    coef = (np.empty(shape) if factors is None else factors) if unit else np.empty(shape, dtype=np.float32)
    inv_tau = np.empty(shape[1:], dtype=np.float32) if with_tau else None
    scale = None if unit else energy_scale(params)

    def batch(i0: int, i1: int) -> None:
        part = slice(i0 - first, i1 - first)
        slab_factors(params, box, i0, i1, coef[:, part], None if inv_tau is None else inv_tau[part], scale)

    side = None if unit or cells is not None else (lambda: axis_cells(params, box))
    computed = slab_batches(box, first, end, batch, side)
    index, factor = (None, None) if unit else cells if cells is not None else computed
    return MannStencil(params, box, coef, inv_tau, index, factor, first, energy)


def stencil_key(params: MannParams, box: BoxShape, with_tau: bool) -> str:
    """Hash of everything the unit stencil depends on (cache file name): all parameters but ae."""
    text = json.dumps(
        {"v": STENCIL_VERSION, "params": asdict(params.with_ae(1.0)), "box": asdict(box), "tau": with_tau},
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def build_stencil(
    params: MannParams,
    box: BoxShape,
    *,
    energy: str = "scaled",
    storage: str = "memory",
    evolving: bool = True,
    slabs: tuple[int, int] | None = None,
    cells=None,
    factors: np.ndarray | None = None,
) -> MannStencil:
    """The stencil of ``params`` on ``box``; ``energy`` "scaled" (float32 for params.ae, with the axis cells) or "unit"
    (ae-free float64); ``storage="on_demand"``: coefficients computed when used; ``evolving=False`` skips 1/tau_e;
    ``slabs`` (first, end) a part of the box; ``cells`` axis_cells computed once; ``factors`` an array to hold a unit
    stencil."""
    if energy not in ENERGIES or storage not in STORAGES:
        raise ValueError(f"energy must be one of {ENERGIES} and storage one of {STORAGES} (got {energy}, {storage})")
    if storage == "on_demand":
        if energy != "scaled" or slabs is not None or factors is not None:
            raise ValueError("a stencil computed on demand is a scaled stencil of the whole box")
        index, factor = cells if cells is not None else axis_cells(params, box)
        return MannStencil(params, box, None, None, index, factor)
    return _build(params, box, energy, evolving and params.evo_time_s is not None, slabs, cells, factors)
