"""The compiled stencil (turbgen.synthesis.mann_factor_kernel) and the batched axis cells against the code they
replaced, bit for bit.

The reference (stencil_reference.py) is the former whole-array numpy stencil; the kernels evaluate the same
float64 operations in the same order and leave log, exp and arctan to the same numpy ufuncs, so every bit must
agree: the float64 ae-free factors, the float32 coefficients and 1/tau_e.
"""

from __future__ import annotations

import numpy as np
import pytest

from stencil_reference import reference_axis_cells, reference_coefficients, reference_unit_factors
from turbgen.synthesis import mann_cells, mann_factors, mann_stencil
from turbgen.synthesis.mann_stencil import BoxShape, build_stencil
from turbgen.theory.eddy_lifetime import TABLE_KL_MAX, TABLE_KL_MIN, LifetimeTable
from turbgen.theory.params import MannParams

BOXES = {
    "even": BoxShape(nt=64, dx_m=4.0, nyp=12, nzp=10, dy_m=6.0, dz_m=5.0),
    "odd": BoxShape(nt=63, dx_m=4.0, nyp=11, nzp=9, dy_m=6.0, dz_m=5.0),
    # kL from ~4e-7 (k1 = dk1, below TABLE_KL_MIN) to ~3e6 (k2 near Nyquist, above TABLE_KL_MAX) at L = 1000 m:
    # the exact lifetimes outside the table's range
    "beyond_table": BoxShape(nt=16, dx_m=1e9, nyp=8, nzp=9, dy_m=1e-3, dz_m=5.0),
}
PARAMS = {
    "guo_evolving": MannParams(ae=0.3, length_scale_m=30.0, gamma=3.2, evo_time_s=20.0),
    "mann_frozen": MannParams(ae=0.3, length_scale_m=49.0, gamma=3.1, evo_time_s=None, lifetime="mann"),
    "isotropic": MannParams(ae=0.3, length_scale_m=30.0, gamma=0.0, evo_time_s=20.0, factor2=10.0),
    "guo_large_L": MannParams(ae=2.0, length_scale_m=1000.0, gamma=1.5, evo_time_s=5.0, factor1=0.8),
}


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a.view(np.uint8), b.view(np.uint8))


@pytest.mark.parametrize("box_name", list(BOXES))
@pytest.mark.parametrize("params_name", list(PARAMS))
def test_stencil_is_bit_identical_to_the_numpy_reference(params_name, box_name):
    params, box = PARAMS[params_name], BOXES[box_name]
    with_tau = params.evo_time_s is not None
    coef, inv_tau = reference_coefficients(params, box, with_tau)
    got = build_stencil(params, box)
    assert _same_bits(got.coef, coef)
    assert (got.inv_tau is None) if inv_tau is None else _same_bits(got.inv_tau, inv_tau)
    factors, unit_inv_tau = reference_unit_factors(params.with_ae(1.0), box, with_tau)
    unit = build_stencil(params, box, energy="unit")
    assert _same_bits(unit.coef, factors)
    assert (unit.inv_tau is None) if unit_inv_tau is None else _same_bits(unit.inv_tau, unit_inv_tau.astype(np.float32))
    assert np.count_nonzero(got.coef[:2]) > got.coef[:2].size // 2  # A and P: not trivially equal


def test_the_beyond_table_box_leaves_the_table_at_both_ends():
    box, L = BOXES["beyond_table"], PARAMS["guo_large_L"].length_scale_m
    ksq = box.k1()[:, None, None] ** 2 + box.k2()[None, :, None] ** 2 + box.k3()[None, None, :] ** 2
    kl = np.sqrt(ksq[ksq > 0]) * L
    assert kl.min() < TABLE_KL_MIN and kl.max() > TABLE_KL_MAX


def test_thread_count_does_not_change_the_stencil(monkeypatch):
    params, box = PARAMS["guo_evolving"], BoxShape(nt=512, dx_m=4.0, nyp=16, nzp=16, dy_m=6.0, dz_m=5.0)
    monkeypatch.setattr(mann_stencil, "_BUILD_POINTS", 2048)  # many batches
    many = build_stencil(params, box)
    monkeypatch.setattr(mann_stencil.os, "cpu_count", lambda: 1)
    one = build_stencil(params, box)
    assert _same_bits(many.coef, one.coef) and _same_bits(many.inv_tau, one.inv_tau)


@pytest.mark.parametrize("kind, parameter", [("mann", 1.0), ("guo", 0.8), ("evolution", 3.5)])
def test_compiled_spline_is_from_ksq(kind, parameter):
    table, L = LifetimeTable(kind, parameter), 7.0
    rng = np.random.default_rng(3)
    kl = np.exp(rng.uniform(np.log(TABLE_KL_MIN) - 2.0, np.log(TABLE_KL_MAX) + 2.0, 20_000))
    ksq = np.concatenate([(kl / L) ** 2, [0.0, (TABLE_KL_MIN / L) ** 2, (TABLE_KL_MAX / L) ** 2]])
    with np.errstate(divide="ignore"):
        log_kl_sq = np.log(ksq * (L * L))
    got = mann_factors._table_half(table, log_kl_sq, lambda: ksq, L)
    assert _same_bits(got, table.from_ksq(ksq, L))
    assert np.isinf(got[-3]) and np.count_nonzero((kl < TABLE_KL_MIN) | (kl >= TABLE_KL_MAX)) > 1000


@pytest.mark.parametrize("params_name", ["guo_evolving", "isotropic"])
@pytest.mark.parametrize(
    "box",
    [BoxShape(nt=512, dx_m=4.0, nyp=16, nzp=16, dy_m=6.0, dz_m=5.0), BoxShape(nt=63, dx_m=4.0, nyp=3, nzp=9, dy_m=6.0, dz_m=5.0)],
)
def test_batched_axis_cells_are_the_slab_by_slab_ones(params_name, box):
    index, factor = mann_cells.axis_cells(PARAMS[params_name], box)
    ref_index, ref_factor = reference_axis_cells(PARAMS[params_name], box)
    assert np.array_equal(index, ref_index) and _same_bits(factor, ref_factor)
    assert len(np.unique(index[:, 0])) > mann_cells._CELL_SLABS  # more than one batch of slabs
