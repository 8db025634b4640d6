"""The Mann tensor, its square-root factor and the eddy lifetimes against independent limits."""

import numpy as np
import pytest
from scipy.special import hyp2f1

from turbgen.errors import ParameterError
from turbgen.theory.eddy_lifetime import GUO_A, evolution_lifetime_s, guo_lifetime, mann_lifetime
from turbgen.theory.mann_tensor import isotropic_variance, sheared_tensor, tensor_factor, von_karman_energy
from turbgen.theory.params import MannParams


def _random_k(n, scale, seed=0):
    return np.random.default_rng(seed).normal(size=(3, n)) * scale


def test_guo_constant_is_eq7():
    # Eq. 7: a = 2F1(1/3, 17/6; 4/3; -1)^(-1/2) ≈ 1.23443 (mann-model.md)
    assert GUO_A == pytest.approx(1.23443, abs=5e-5)
    assert GUO_A == pytest.approx(hyp2f1(1 / 3, 17 / 6, 4 / 3, -1.0) ** -0.5, rel=1e-14)


@pytest.mark.parametrize("factor1", [1.0, 0.8])
def test_guo_lifetime_slopes(factor1):
    # log-log slope -factor1 as kL -> 0 and -2/3 as kL -> inf (Eq. 6 as written)
    lo = np.log(guo_lifetime(2e-4, factor1) / guo_lifetime(1e-4, factor1)) / np.log(2)
    hi = np.log(guo_lifetime(2e4, factor1) / guo_lifetime(1e4, factor1)) / np.log(2)
    assert lo == pytest.approx(-factor1, abs=1e-6)
    assert hi == pytest.approx(-2 / 3, abs=1e-6)
    assert guo_lifetime(1.0, factor1) == pytest.approx(GUO_A * 2 ** ((-2 / 3 + factor1) / 10), rel=1e-12)


def test_mann_lifetime_slopes_and_value():
    lo = np.log(mann_lifetime(2e-4) / mann_lifetime(1e-4)) / np.log(2)
    hi = np.log(mann_lifetime(2e4) / mann_lifetime(1e4)) / np.log(2)
    assert lo == pytest.approx(-1.0, abs=1e-3)
    assert hi == pytest.approx(-2 / 3, abs=1e-3)
    # at kL = 1 the hypergeometric form equals Guo's constant a by construction (Eq. 7)
    assert mann_lifetime(1.0) == pytest.approx(GUO_A, rel=1e-12)


def test_evolution_lifetime_eq15():
    p = MannParams(ae=0.3, length_scale_m=49.0, gamma=3.1, evo_time_s=400.0)
    k = np.array([1e-4, 0.01, 1.0]) / 49.0
    kL = k * 49.0
    expected = 400.0 * GUO_A / kL * (kL**10 + 1) ** (-2 / 15)
    np.testing.assert_allclose(evolution_lifetime_s(k, p), expected, rtol=1e-12)
    frozen = MannParams(ae=0.3, length_scale_m=49.0, gamma=3.1, evo_time_s=None)
    assert np.all(np.isinf(evolution_lifetime_s(k, frozen)))


def test_factor_reproduces_tensor():
    p = MannParams(ae=0.311, length_scale_m=49.0, gamma=3.1)
    k = _random_k(2000, 0.05)
    k[0, :50] = 0.0  # the k1 = 0 plane uses exact limits
    phi = sheared_tensor(*k, p)
    c = tensor_factor(*k, p)
    cct = np.einsum("ik...,jk...->ij...", c, c)
    np.testing.assert_allclose(cct, phi, atol=1e-12 * np.abs(phi).max())
    # positive semi-definite and symmetric
    eig = np.linalg.eigvalsh(np.moveaxis(phi, (0, 1), (-2, -1)))
    assert eig.min() > -1e-10 * eig.max()
    np.testing.assert_array_equal(phi, np.swapaxes(phi, 0, 1))


def test_factor_is_odd_in_k():
    # C(-k) = -C(k): the synthesis relies on it for Hermitian symmetry
    p = MannParams(ae=1.0, length_scale_m=30.0, gamma=2.4, factor1=0.8)
    k = _random_k(500, 0.1, seed=1)
    np.testing.assert_allclose(tensor_factor(*(-k), p), -tensor_factor(*k, p), rtol=1e-12, atol=1e-14)


def test_k1_zero_limit_is_continuous():
    p = MannParams(ae=1.0, length_scale_m=49.0, gamma=3.1)
    at_zero = sheared_tensor(0.0, 0.02, 0.013, p)
    near_zero = sheared_tensor(1e-10, 0.02, 0.013, p)
    np.testing.assert_allclose(at_zero, near_zero, rtol=1e-6, atol=1e-9 * np.abs(at_zero).max())
    # on the k3 axis (q = 0) w carries no energy and nothing is NaN
    axis = sheared_tensor(0.0, 0.0, 0.01, p)
    assert np.all(np.isfinite(axis)) and axis[2, 2] == 0.0


def test_isotropic_limit_gamma_zero():
    # Gamma = 0: Phi_ij = E(k)/(4 pi k^4) (k^2 delta_ij - k_i k_j)
    p = MannParams(ae=0.5, length_scale_m=40.0, gamma=0.0)
    k = _random_k(300, 0.05, seed=2)
    ksq = (k**2).sum(0)
    e = von_karman_energy(np.sqrt(ksq), 0.5, 40.0)
    iso = e / (4 * np.pi * ksq**2) * (ksq * np.eye(3)[:, :, None] - k[:, None] * k[None, :])
    np.testing.assert_allclose(sheared_tensor(*k, p), iso, rtol=1e-10, atol=1e-12 * np.abs(iso).max())


def test_isotropic_variance_closed_form():
    # sigma^2 = (1/3) B(5/2, 1/3) ae L^(2/3) = 0.68834 ae L^(2/3) (mann-model.md)
    assert isotropic_variance(1.0, 1.0) == pytest.approx(0.68834, abs=1e-5)
    # and equals (2/3) ∫ E(k) dk, computed independently
    from scipy.integrate import quad

    tke, _ = quad(lambda x: von_karman_energy(np.exp(x), 0.7, 25.0) * np.exp(x), -30, 30, limit=800, epsabs=0, epsrel=1e-11)
    assert isotropic_variance(0.7, 25.0) == pytest.approx(2 / 3 * tke, rel=1e-8)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(ae=-1, length_scale_m=49, gamma=3.1),
        dict(ae=1, length_scale_m=0, gamma=3.1),
        dict(ae=1, length_scale_m=49, gamma=-0.1),
        dict(ae=float("nan"), length_scale_m=49, gamma=3.1),
        dict(ae=1, length_scale_m=49, gamma=3.1, evo_time_s=0),
        dict(ae=1, length_scale_m=49, gamma=3.1, lifetime="foo"),
    ],
)
def test_bad_parameters_raise_one_line(kwargs):
    with pytest.raises(ParameterError) as exc:
        MannParams(**kwargs)
    assert "\n" not in str(exc.value)
