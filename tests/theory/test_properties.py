"""Property-based checks (hypothesis) of identities that must hold for any input."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from turbgen.cli.options import parse_ints
from turbgen.grid import Grid
from turbgen.theory.coherence_models import exponential_longitudinal, exponential_yz, kristensen
from turbgen.theory.mann_tensor import sheared_tensor, tensor_factor
from turbgen.theory.params import MannParams

wavenumber = st.floats(min_value=-10.0, max_value=10.0, allow_nan=False).map(lambda v: v * 0.05)
mann = st.builds(
    MannParams,
    ae=st.floats(0.01, 2.0),
    length_scale_m=st.floats(5.0, 300.0),
    gamma=st.floats(0.0, 5.0),
    lifetime=st.sampled_from(["guo", "mann"]),
    factor1=st.floats(0.5, 1.5),
)


@settings(max_examples=200, deadline=None)
@given(mann, wavenumber, wavenumber, wavenumber)
def test_factor_squares_to_the_tensor_for_any_k(params, k1, k2, k3):
    phi = sheared_tensor(k1, k2, k3, params)
    c = tensor_factor(k1, k2, k3, params)
    scale = max(np.abs(phi).max(), 1e-300)
    np.testing.assert_allclose(c @ c.T, phi, atol=1e-10 * scale)
    # the tensor is a covariance: symmetric with non-negative diagonal and |Phi_ij|^2 <= Phi_ii Phi_jj
    diag = np.diag(phi)
    assert np.all(diag >= -1e-12 * scale)  # rounding only: Phi_11 = 0 exactly along k1 at Gamma = 0
    d = np.clip(diag, 0.0, None)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        # rounding of a cancellation like k0^2 - k2^2 is O(eps * scale) per entry, so O(eps * scale^2) here
        assert phi[i, j] ** 2 <= d[i] * d[j] + 1e-13 * scale**2


@given(st.floats(0.0, 500.0), st.floats(0.0, 5.0), st.floats(1.0, 30.0))
def test_coherences_are_in_unit_interval_and_one_at_zero_separation(r, f, U):
    for value in (exponential_yz(r, f, U), exponential_longitudinal(r, f, U, 1.8, 1.5e-4), kristensen(r, f, U, 3.5, 340.2)):
        assert 0.0 <= float(value) <= 1.0
    assert exponential_yz(0.0, f, U) == 1.0 and kristensen(0.0, f, U, 3.5, 340.2) == 1.0


@given(st.lists(st.integers(0, 500), min_size=1, max_size=20))
def test_seed_lists_round_trip(values):
    assert parse_ints(",".join(map(str, values)), "--seeds") == sorted(set(values))


@given(st.integers(1, 200), st.integers(1, 200), st.floats(0.1, 50.0), st.floats(0.1, 50.0))
def test_grid_is_centred_on_the_hub(ny, nz, dy, dz):
    g = Grid(nt=4, dt_s=1.0, x_m=(0.0,), ny=ny, nz=nz, dy_m=dy, dz_m=dz)
    np.testing.assert_allclose(g.y() + g.y()[::-1], 0.0, atol=1e-9 * dy * ny)
    np.testing.assert_allclose(g.z() + g.z()[::-1], 0.0, atol=1e-9 * dz * nz)
    np.testing.assert_allclose(np.diff(g.y()), dy) if ny > 1 else None
