"""KaimalEvo takes its yz coherence as a plain function coh(r_m, f_hz); the IEC exponential is the default."""

from __future__ import annotations

from functools import partial

import numpy as np

from turbgen.grid import Grid
from turbgen.synthesis.kaimal_evo import KaimalEvo
from turbgen.theory.coherence_models import exponential_longitudinal, exponential_yz, exponential_yz_decay_length_m
from turbgen.theory.kaimal import iec_kaimal_params

U = 12.0
KP = iec_kaimal_params(U, "B", 90.0)
EXP = partial(exponential_longitudinal, U_m_s=U, a_x=1.8, b_x=1.49e-4)
GRID = Grid(256, 0.5, (0.0, 40.0), 4, 3, 10.0, 8.0)


def _field(gen, c="u"):
    """(nx, nt, ny, nz) float32 of one component."""
    return np.stack([p for _, p in gen.component_planes(c)])


def test_the_default_is_the_iec_exponential_given_as_a_function():
    default = _field(KaimalEvo(KP, GRID, U, 4, long_coherence=EXP))
    coh = partial(exponential_yz, U_m_s=U, a_yz=KP.a_yz, lc_m=KP.lc_m)
    decay = partial(exponential_yz_decay_length_m, U_m_s=U, a_yz=KP.a_yz, lc_m=KP.lc_m)
    given = _field(KaimalEvo(KP, GRID, U, 4, long_coherence=EXP, yz_coherence=coh, yz_decay_length_m=decay))
    assert np.array_equal(default, given)


def test_full_coherence_makes_every_plane_uniform_in_y_and_z():
    def one(r_m, f_hz):
        return np.ones_like(np.asarray(r_m, dtype=float))

    gen = KaimalEvo(KP, GRID, U, 9, long_coherence=EXP, yz_coherence=one, coherent_vw=True)
    for c in "uvw":
        x = _field(gen, c)
        spread = x - x[:, :, :1, :1]  # every point minus the point (y0, z0) of its plane and time
        assert float(x.std()) > 0.1
        assert float(np.abs(spread).max()) < 1e-5 * float(np.abs(x).max()), c
    white_v = _field(KaimalEvo(KP, GRID, U, 9, long_coherence=EXP, yz_coherence=one), "v")
    assert float(np.abs(white_v - white_v[:, :, :1, :1]).max()) > 0.1 * float(white_v.std())  # v stays white
