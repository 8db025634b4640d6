"""The ae-free part of a Mann stencil, to serve every energy level bit-identically (Mann.rs and hipersim likewise
build for ae = 1 and scale).

``build_unit_stencil`` keeps the float64 factors (e, k30, c1, c2) of ``mann_stencil.slab_factors``;
``scale_stencil`` forms from them the float32 (A, P, Z1, Z2) of any ae by the float64 operations
``mann_stencil.build_stencil`` applies, so a scaled stencil equals a direct build bit for bit.
turbgen.runs.stencil_cache keeps unit stencils on disk.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.synthesis.mann_cells import axis_cells
from turbgen.synthesis.mann_stencil import BoxShape, MannStencil, energy_scale, slab_batches, slab_factors
from turbgen.theory.params import MannParams


@dataclass(frozen=True, eq=False)
class UnitMannStencil:
    """The part of a stencil that does not depend on ae (Mann.rs and hipersim likewise build for ae = 1 and scale).

    ``factors`` (4, nk1, nyp//2+1, nzp) float64 holds (e, k30, c1, c2) of mann_stencil.slab_factors, from which
    scale_stencil forms the float32 (A, P, Z1, Z2) of any ae bit-identically to build_stencil (a float32
    stencil for ae = 1 times sqrt(ae) would differ in the last bit). ``inv_tau`` as in MannStencil
    (it does not depend on ae). ``params`` carry ae = 1.
    """

    params: MannParams
    box: BoxShape
    factors: np.ndarray
    inv_tau: np.ndarray | None


def unit_stencil_nbytes(box: BoxShape, with_tau: bool) -> int:
    """Bytes [B] held by the UnitMannStencil of ``box``: four float64 factors, float32 1/tau_e if ``with_tau``."""
    per = box.nk1 * box.nk2_half * box.nzp
    return per * (36 if with_tau else 32)


def apply_energy(unit: np.ndarray, energy: float, k1, scale: float, out: np.ndarray) -> np.ndarray:
    """(A, P, Z1, Z2) times sqrt(dk / 2) = ``scale`` into ``out`` (4, b, nh, nzp) float64 from the ``unit`` factors.

    a = e ``energy`` (energy_scale), P = k30 a, Z1 = c1 a, Z2 = c2 a, A = a except on the k3 axis
    (k1 = k2 = 0, where A is never used: m = 0 and k2 = 0). mann_factor_kernel.mann_factors applies the
    energy by the same float64 operations in the same order when it builds a stencil directly, so a scaled
    unit stencil is bit-identical to a direct build.
    """
    a, p, z1, z2 = out
    np.multiply(unit[0], energy, out=a)
    np.multiply(unit[1], a, out=p)
    np.multiply(unit[2], a, out=z1)
    np.multiply(unit[3], a, out=z2)
    for i in np.flatnonzero(k1[:, 0, 0] == 0.0):
        a[i, 0] = 0.0  # row 0 is k2 = 0
    out *= scale
    return out


def build_unit_stencil(
    params: MannParams, box: BoxShape, *, evolving: bool = True, factors: np.ndarray | None = None
) -> UnitMannStencil:
    """The ae-free stencil of ``params`` on ``box``, to serve every ae through scale_stencil.

    Building it costs what build_stencil costs; scaling it, a few multiplications per point.

    Parameters
    ----------
    params : Mann parameters; ae is ignored (the result carries ae = 1).
    box : the synthesis box.
    evolving : False skips 1/tau_e (a stencil for single snapshots), as in build_stencil.
    factors : optional (4, nk1, nyp//2+1, nzp) float64 array to hold the factors (e.g. a file mapped
        by the stencil cache); by default they are allocated: twice the bytes of a MannStencil's
        coefficients (unit_stencil_nbytes).

    Returns
    -------
    UnitMannStencil
    """
    with_tau = evolving and params.evo_time_s is not None
    nh, nzp = box.nk2_half, box.nzp
    unit_params = params.with_ae(1.0)
    factors = np.empty((4, box.nk1, nh, nzp)) if factors is None else factors
    inv_tau = np.empty((box.nk1, nh, nzp), dtype=np.float32) if with_tau else None

    def batch(i0: int, i1: int) -> None:
        slab_factors(unit_params, box, i0, i1, factors[:, i0:i1], None if inv_tau is None else inv_tau[i0:i1], None)

    slab_batches(box, 0, box.nk1, batch)
    return UnitMannStencil(unit_params, box, factors, inv_tau)


def scale_stencil(unit: UnitMannStencil, params: MannParams) -> MannStencil:
    """The stencil of ``params`` (ae included) from the ae-free ``unit`` stencil.

    Bit-identical to build_stencil(params, unit.box): the energy enters by the same float64 operations
    at the same point (apply_energy), then the coefficients are rounded to float32. The axis cells
    (a few hundred 3 x 3 factors) are computed for ``params``: their eigen-decomposition is not
    linear in ae to the last bit.

    Parameters
    ----------
    unit : from build_unit_stencil (or the stencil cache) of parameters equal to ``params`` but for ae.
    params : the run's parameters, ae [m^(4/3) s^-2] included.

    Returns
    -------
    MannStencil : sharing ``unit.inv_tau`` (1/tau_e does not depend on ae).

    Raises
    ------
    ValueError : ``unit`` was built for parameters that differ from ``params`` in more than ae.
    """
    if params.with_ae(1.0) != unit.params:
        raise ValueError("the unit stencil was built for other parameters than ae")
    box = unit.box
    nh, nzp = box.nk2_half, box.nzp
    scale = np.sqrt(np.prod(box.dk()) / 2.0)
    energy = energy_scale(params)
    k1_all = box.k1()
    coef = np.empty((4, box.nk1, nh, nzp), dtype=np.float32)

    def batch(i0: int, i1: int) -> None:
        work = np.empty((4, i1 - i0, nh, nzp))
        coef[:, i0:i1] = apply_energy(unit.factors[:, i0:i1], energy, k1_all[i0:i1, None, None], scale, work)

    index, factor = slab_batches(box, 0, box.nk1, batch, lambda: axis_cells(params, box))
    return MannStencil(params, box, coef, unit.inv_tau, index, factor)
