"""The compiled prior components of a slab (conditioning._slab_components, used by S and the correction) equal the
products of the oracle's factor (mann_oracle.slab_factor, Phi = 2 C C^T) bit for bit: the same float64 operations
from the same float32 stencil, on every slab kind (k1 = 0 with its axis cells, ordinary, Nyquist), an even and an
odd box width, a stored and an on-demand stencil, and on the first rows only."""

from __future__ import annotations

import numpy as np
import pytest

from turbgen.synthesis.conditioning import COMPONENT_PAIRS, _slab_components
from turbgen.synthesis.mann_oracle import slab_factor
from turbgen.synthesis.mann_stencil import BoxShape, build_stencil
from turbgen.theory.params import MannParams

PARAMS = MannParams(ae=0.05, length_scale_m=30.0, gamma=3.1, evo_time_s=20.0)


def _oracle(stencil, i):
    c = slab_factor(stencil, i)
    return np.stack([2.0 * (c[a, 0] * c[b, 0] + c[a, 1] * c[b, 1] + c[a, 2] * c[b, 2]) for a, b in COMPONENT_PAIRS])


@pytest.mark.parametrize("nyp", [8, 7])
@pytest.mark.parametrize("storage", ["memory", "on_demand"])
def test_components_equal_the_oracles_products(nyp, storage):
    box = BoxShape(32, 10.0, nyp, 6, 10.0, 10.0)
    stencil = build_stencil(PARAMS, box, storage=storage)
    assert stencil.cells_in(0, 1).stop > stencil.cells_in(0, 1).start  # the k1 = 0 slab has axis cells
    for i in (0, 1, 5, box.nk1 - 1):
        ref = _oracle(stencil, i)
        got = _slab_components(stencil, i, nyp).reshape(ref.shape)
        assert np.array_equal(got, ref), i
        rows = nyp // 2 + 1
        assert np.array_equal(_slab_components(stencil, i, rows).reshape(6, rows, -1), ref[:, :rows])
    # the odd component's sign on the rows k2 < 0 matters: Phi_12 and Phi_23 are odd in k2 there
    assert np.abs(ref[4, nyp - 1]).max() > 0 and np.array_equal(ref[4, nyp - 1], -ref[4, 1])
