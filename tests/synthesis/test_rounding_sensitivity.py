"""No discrete branch of the synthesis may hang on the last bits of a floating-point value.

Another CPU (SIMD level, libm, BLAS kernels) rounds the same formulas differently by an ulp or so. Each factor that
turns noise into a field is recomputed here from inputs perturbed by a few ulps (relative 4e-16, random signs); it
must move by round-off, not by O(1). The former eigenvector factor V sqrt(Lambda) of the axis cells failed this:
98 of 825 cell factors of a 64 x 12 x 12 box changed by O(1) (column signs flipped).
"""

from __future__ import annotations

import numpy as np
import pytest

import turbgen.synthesis.circulant as circulant
import turbgen.synthesis.mann_cells as mann_cells
from turbgen.synthesis.kaimal_evo import longitudinal_factors
from turbgen.synthesis.mann_stencil import BoxShape
from turbgen.theory.params import MannParams

ULPS = 4e-16


def _perturbed(values: np.ndarray, seed: int) -> np.ndarray:
    return values * (1.0 + ULPS * np.random.default_rng(seed).standard_normal(np.shape(values)))


@pytest.mark.parametrize("lifetime", ["guo", "mann"])
def test_axis_cell_factors_move_by_round_off_only(monkeypatch, lifetime):
    params = MannParams(1.0, 49.0, 3.1, lifetime=lifetime)
    box = BoxShape(64, 8.0, 12, 12, 4.7, 4.7)
    _, exact = mann_cells.axis_cells(params, box)
    tensor = mann_cells.sheared_tensor
    monkeypatch.setattr(mann_cells, "sheared_tensor", lambda *a, **k: _perturbed(tensor(*a, **k), 1))
    _, moved = mann_cells.axis_cells(params, box)
    # Hölder-1/2 bound sqrt(|dA|) ~ 2e-8 |A|^(1/2), below float32 resolution (6e-8 relative)
    assert np.abs(moved - exact).max() <= 1e-6 * np.abs(exact).max()


@pytest.mark.parametrize("decay_m", [3.0, 40.0, 1e4])  # a near-singular C (coherence ~1 across the grid) included
def test_dense_yz_factor_moves_by_round_off_only(decay_m):
    kernel = lambda r: np.exp(-r / decay_m)  # noqa: E731
    exact = circulant.dense_embedding(kernel, 5, 6, 4.0, 4.0).chol
    moved = circulant.dense_embedding(lambda r: _perturbed(kernel(r), 2), 5, 6, 4.0, 4.0).chol
    assert np.abs(moved - exact).max() <= 1e-6


def test_longitudinal_factors_move_by_round_off_only():
    coh = lambda dx, f: np.exp(-12.0 * dx * f / 10.0)  # noqa: E731  down to f = 0: all ones, rank 1
    x, f = np.arange(0.0, 220.0, 20.0), np.linspace(0.0, 1.0, 64)
    exact, _ = longitudinal_factors(coh, x, f)
    moved, _ = longitudinal_factors(lambda dx, ff: _perturbed(coh(dx, ff), 3), x, f)
    assert np.abs(moved - exact).max() <= 1e-6
