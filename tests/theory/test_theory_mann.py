"""Mann spectra, coherences, variances, space-time coherence and REWS against independent limits and
against a refined quadrature (convergence). Tolerances are the measured errors times ~3-10."""

import numpy as np
import pytest

from turbgen.errors import ParameterError
from turbgen.theory import mann_quadrature as mq
from turbgen.theory import mann_spectra as ms
from turbgen.theory.mann_tensor import isotropic_variance, sheared_tensor
from turbgen.theory.params import MannParams
from turbgen.theory.rotor_effective import rews_spectrum_mann
from turbgen.theory.space_time import longitudinal_coherence, space_time_tensor

L = 33.6
IEC = MannParams(1.0, L, 3.9, lifetime="mann", evo_time_s=None)
NEUTRAL = MannParams(0.311, 49.0, 3.1, evo_time_s=400.0)
STABLE = MannParams(0.652, 30.0, 2.4, factor1=0.8, evo_time_s=200.0)


def _quad(k1, p, rule, d=(0.0, 0.0), pairs=((0, 0), (1, 1), (2, 2), (0, 2))):
    _, w, g = mq.perpendicular_quadrature(k1, p, pairs, *d, _rule=rule)
    return {q: (w * g[q]).sum(-1) for q in pairs}


def test_isotropic_closed_form():
    # Gamma = 0: F11(k1) = (9/55) ae (L^-2 + k1^2)^(-5/6) (two-sided isotropic von Karman), F22 = F33
    p = MannParams(0.7, L, 0.0)
    k1 = np.logspace(-3, 3, 25) / L
    F = ms.one_point_spectra(k1, p)
    exact = 9.0 / 55.0 * 0.7 * (L**-2 + k1**2) ** (-5.0 / 6.0)
    np.testing.assert_allclose(F["F11"], exact, rtol=1e-6)
    np.testing.assert_allclose(F["F22"], F["F33"], rtol=1e-6)
    assert np.max(np.abs(F["F13"]) / F["F11"]) < 1e-12


def test_isotropic_variances():
    p = MannParams(0.7, L, 0.0)
    v = ms.variances(p)
    s2 = isotropic_variance(0.7, L)  # 0.68834 ae L^(2/3)
    assert s2 == pytest.approx(0.68834 * 0.7 * L ** (2 / 3), rel=1e-5)
    for key in ("uu", "vv", "ww"):
        assert v[key] == pytest.approx(s2, rel=1e-5)
    assert abs(v["uw"]) < 1e-9 * s2


def test_published_iec_ratios():
    # Mann (1994) / IEC 61400-1: Gamma = 3.9, L = 33.6 m, Eq. 4 lifetime
    v = ms.variances(IEC)
    assert np.sqrt(v["vv"] / v["uu"]) == pytest.approx(0.71, abs=0.01)
    assert np.sqrt(v["ww"] / v["uu"]) == pytest.approx(0.52, abs=0.01)
    assert v["uw"] / v["uu"] == pytest.approx(-0.24, abs=0.01)


def test_ae_for_sigma_u_round_trip():
    ae = ms.ae_for_sigma_u(2.816, NEUTRAL)
    assert np.sqrt(ms.variances(NEUTRAL.with_ae(ae))["uu"]) == pytest.approx(2.816, rel=1e-10)
    # Guo et al. (2023), Table 1: ae = 0.311 gives sigma_u within a few % of 2.82 m/s
    assert ae == pytest.approx(0.311, rel=0.05)


@pytest.mark.parametrize("p", [IEC, NEUTRAL, STABLE])
def test_ae_for_sigma_u_integrates_f11_alone_to_the_same_bits(p):
    """ae_for_sigma_u integrates F11 alone (the other spectra are not needed): the same float as sigma_u^2 over the
    full variances' uu, so fields whose ae comes from sigma_u keep their bits (tests/synthesis/test_pinned_fields)."""
    assert ms.ae_for_sigma_u(1.7, p) == 1.7 * 1.7 / ms.variances(p.with_ae(1.0))["uu"]


def test_variances_do_not_read_the_evolution():
    """The variances are cached without evo_time_s and factor2 (one-point statistics at zero time lag): computed
    afresh, an evolving and a frozen shape with another factor2 give the same bits."""
    frozen = MannParams(STABLE.ae, STABLE.length_scale_m, STABLE.gamma, factor1=0.8, factor2=2.0, evo_time_s=None)
    assert ms._variances_cached.__wrapped__(STABLE) == ms._variances_cached.__wrapped__(frozen)


@pytest.mark.parametrize("p", [IEC, STABLE], ids=["iec-mann", "stable-guo"])
def test_one_point_convergence(p):
    # refined rule: 2x panels, 12 Gauss nodes, 512 angles everywhere, radial range to 1e5 s
    k1 = np.logspace(-3, 3, 7) / p.length_scale_m
    a = _quad(k1, p, {})
    b = _quad(k1, p, dict(n_theta=512, n_gauss=12, panel_ln=0.5, x_hi=1e5))
    for q in ((0, 0), (1, 1), (2, 2)):
        assert np.max(np.abs(a[q] / b[q] - 1)) < 2e-5  # measured <= 4e-6
    assert np.max(np.abs(a[(0, 2)] - b[(0, 2)]) / np.sqrt(b[(0, 0)] * b[(2, 2)])) < 1e-6  # measured 7e-8


def test_coherence_convergence():
    k1 = np.logspace(-1.5, 1, 5) / L
    d = (20.0, 20.0)
    rule = dict(n_theta=256, n_gauss=12, panel_ln=0.5, x_hi_sep=60.0)
    a = _quad(k1, IEC, {}, d, ((0, 0), (0, 2)))
    b = _quad(k1, IEC, rule, d, ((0, 0), (0, 2)))
    a0 = _quad(k1, IEC, {})
    assert np.max(np.abs(a[(0, 0)] - b[(0, 0)]) / a0[(0, 0)]) < 5e-4  # measured <= 7e-5
    assert np.max(np.abs(a[(0, 2)] - b[(0, 2)]) / np.sqrt(a0[(0, 0)] * a0[(2, 2)])) < 2e-4  # measured 1e-5


def test_bessel_recurrence_is_scipys_jv():
    """The Jacobi-Anger orders J_0 .. J_255 by backward recurrence equal scipy's jv to the recurrence's round-off:
    it starts at order top = 673 here (z <= 400), each step and the normalising sum rounding at eps of max |J| <= 1,
    so top x eps = 1.5e-13 absolute bounds it (measured 1.2e-14); z = 0 and tiny z (rescaled steps) included."""
    from scipy.special import jv

    z = np.append(0.0, np.geomspace(1e-9, 400.0, 2999)).reshape(30, 100)
    assert np.abs(mq._bessel_j(255, z) - jv(np.arange(256), z[..., None])).max() < 1.5e-13


def test_coherence_limits_and_monotonicity():
    k1 = np.array([0.003, 0.01, 0.03, 0.1])
    coh_small, co_small = ms.yz_coherence(k1, NEUTRAL, 0, 0, 0.01, 0.0)
    assert np.all(coh_small > 0.999) and np.all(co_small > 0.999)
    # while the coherence is significant it decreases with separation and with frequency
    # (at larger k1 d the lateral u coherence oscillates around 0, co-coherence goes negative)
    k1 = np.array([0.001, 0.003, 0.01, 0.03])
    cohs = [ms.yz_coherence(k1, NEUTRAL, 0, 0, d, 0.0)[0] for d in (2.0, 10.0, 30.0)]
    assert np.all(cohs[0] > cohs[1]) and np.all(cohs[1] > cohs[2])
    for c in cohs:
        assert np.all(np.diff(c) < 0)
    # the cross-spectrum is the complex conjugate for -k1 (real field)
    fp = ms.cross_spectrum([0.02], NEUTRAL, 0, 2, 10.0, 5.0)
    fm = ms.cross_spectrum([-0.02], NEUTRAL, 0, 2, 10.0, 5.0)
    np.testing.assert_allclose(fm, np.conj(fp), rtol=1e-10)


def test_bad_component():
    with pytest.raises(ParameterError):
        ms.cross_spectrum([0.1], NEUTRAL, 0, 3)


def test_space_time_tensor_at_zero_lag_is_phi():
    rng = np.random.default_rng(1)
    k = rng.normal(size=(3, 50)) / L
    np.testing.assert_array_equal(space_time_tensor(*k, 0.0, NEUTRAL), sheared_tensor(*k, NEUTRAL))
    theta = space_time_tensor(*k, 10.0, NEUTRAL)
    phi = sheared_tensor(*k, NEUTRAL)
    ratio = theta[0, 0] / phi[0, 0]
    assert np.all((ratio > 0) & (ratio < 1))


def test_longitudinal_coherence():
    f = np.logspace(-3, -0.5, 8)
    frozen = MannParams(0.311, 49.0, 3.1, evo_time_s=None)
    np.testing.assert_allclose(longitudinal_coherence(f, 100.0, 16.0, frozen), 1.0)
    # dx -> 0: coh2 -> 1 (slowly at high f: tau_e ~ k^(-7/3) decorrelates the smallest eddies at once)
    near = [longitudinal_coherence(f, dx, 16.0, NEUTRAL) for dx in (1e-1, 1e-3, 1e-6)]
    assert np.all(near[0] < near[1]) and np.all(near[1] < near[2]) and np.all(near[2] > 0.9999)
    c50, c100 = longitudinal_coherence(f, 50.0, 16.0, NEUTRAL), longitudinal_coherence(f, 100.0, 16.0, NEUTRAL)
    assert np.all(c100 < c50) and np.all(np.diff(c100) < 0)


def test_rews_limits(monkeypatch):
    from turbgen.theory import rotor_effective

    k1 = np.logspace(-3, 0, 6)
    f11 = ms.one_point_spectra(k1, NEUTRAL)["F11"]
    np.testing.assert_allclose(rews_spectrum_mann(k1, NEUTRAL, 1e-5), f11, rtol=1e-6)
    big = rews_spectrum_mann(k1, NEUTRAL, 63.0)
    assert np.all(big < f11) and np.all(np.diff(big / f11) < 0)
    # resolving the J1^2 oscillation much further changes the result by < 1e-5 relative (measured 1e-6)
    monkeypatch.setattr(rotor_effective, "Z_SMOOTH", 200.0)
    monkeypatch.setattr(rotor_effective, "SMOOTH_S", 16.0)
    ref = rews_spectrum_mann(k1, NEUTRAL, 63.0)
    assert np.max(np.abs(big / ref - 1)) < 1e-5


def test_k1_zero_is_the_limit():
    # the distortion puts a finite part of F11 at kappa ~ k1 as k1 -> 0; F(0) must be that limit
    # (the tensor's exact k1 = 0 plane alone gives ~4x less), and F is even in k1
    k1 = np.array([0.0, 1e-7, 1e-6, -1e-6])
    F = ms.one_point_spectra(k1, NEUTRAL)
    for name in ("F11", "F22", "F33", "F13"):
        assert F[name][0] == pytest.approx(F[name][1], rel=2e-3)
        assert F[name][1] == pytest.approx(F[name][2], rel=1e-2)
        assert F[name][2] == pytest.approx(F[name][3], rel=1e-12)


def test_variance_is_integral_of_spectrum_sheared():
    # sigma_i^2 = ∫ F_ii dk1 over all k1 (two-sided): an independent adaptive quadrature in ln k1
    from functools import lru_cache

    from scipy.integrate import quad

    @lru_cache(maxsize=None)  # the three quadratures share most nodes: each k1's spectra computed once
    def spectra(t):
        return ms.one_point_spectra([np.exp(t)], NEUTRAL)

    def integrand(t, name):
        return 2.0 * np.exp(t) * spectra(t)[name][0]

    v = ms.variances(NEUTRAL)
    lo, hi = np.log(1e-7 / 49.0), np.log(1e6 / 49.0)
    for name, key in (("F11", "uu"), ("F33", "ww"), ("F13", "uw")):
        body, _ = quad(integrand, lo, hi, args=(name,), limit=200, epsrel=1e-8)
        tail = 0.0 if name == "F13" else 2.0 * 1.5 * np.exp(hi) * ms.one_point_spectra([np.exp(hi)], NEUTRAL)[name][0]
        assert v[key] == pytest.approx(body + tail, rel=1e-5)


def test_quadrature_threads_do_not_change_the_numbers(monkeypatch):
    """perpendicular_quadrature evaluates its batches on threads: every batch fills its own rows."""
    p = MannParams(ae=0.7, length_scale_m=30.0, gamma=2.5, lifetime="mann")
    k1 = np.geomspace(1e-4, 10.0, 40)
    monkeypatch.setattr(mq, "_CHUNK_POINTS", 20_000)  # many batches
    monkeypatch.setattr(mq, "_QUADRATURE_THREADS", 3)
    threaded = ms.one_point_spectra(k1, p), ms.cross_spectrum(k1, p, 0, 2, 5.0, 3.0)
    monkeypatch.setattr(mq, "_QUADRATURE_THREADS", 1)
    serial = ms.one_point_spectra(k1, p), ms.cross_spectrum(k1, p, 0, 2, 5.0, 3.0)
    for name in serial[0]:
        assert np.array_equal(threaded[0][name], serial[0][name]), name
    assert np.array_equal(threaded[1], serial[1])
