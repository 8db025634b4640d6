"""Unit tests of the validator's building blocks: Welch setup, expected-Welch kernel, coherence statistics."""

import numpy as np
import pytest
import scipy.signal

from turbgen.grid import Grid
from turbgen.errors import ParameterError
from turbgen.validation.band_checks import COHERENCE_FLOOR, coherence_stats
from turbgen.validation.estimators import WelchSetup, default_nperseg, plan_spans, welch_series
from turbgen.validation.pair_sums import rect_pair_counts, set_pair_counts
from turbgen.validation.point_sets import check_rotor_radius, default_separations, rotor_mask
from turbgen.validation.welch_kernel import WelchKernel


def test_hann_correlations_match_welch_1967():
    s = WelchSetup(256, 0.5)
    assert s.overlap_rho2 == pytest.approx(1 / 36, rel=1e-12)  # (sum w_t w_{t+n/2} / sum w^2)^2 = (1/6)^2
    assert s.bin_rho2(1) == pytest.approx(4 / 9, rel=1e-12)
    assert s.bin_rho2(2) == pytest.approx(1 / 36, rel=1e-12)
    assert s.bin_rho2(3) == pytest.approx(0.0, abs=1e-20)


@pytest.mark.parametrize("n", [32, 33, 256, 4096])
def test_hann_window_is_the_periodic_hann(n):
    # scipy's window is the periodic Hann law 1/2 - 1/2 cos(2 pi k / N) (to round-off) and sums to N / 2
    k = np.arange(n)
    w = WelchSetup(n, 0.5).window
    np.testing.assert_allclose(w, 0.5 - 0.5 * np.cos(2 * np.pi * k / n), rtol=0, atol=4.5e-16)
    assert w.sum() == pytest.approx(n / 2, rel=1e-14)


def test_welch_series_matches_scipy_density():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((4096, 3))
    s = WelchSetup(256, 0.25)
    psd, k, pairs = welch_series(x, s)
    _, ref = scipy.signal.welch(x, fs=4.0, window="hann", nperseg=256, noverlap=128, axis=0)
    assert k == 31 and pairs == 30
    np.testing.assert_allclose(psd[1:-1], ref.mean(axis=1)[1:-1], rtol=1e-10)


def test_kernel_is_the_exact_expectation_of_a_line():
    # a single line Z e^{i 2 pi f t}: the windowed, mean-removed DFT is Z G_m(f) exactly
    nt, n, dt = 1024, 64, 0.5
    s = WelchSetup(n, dt)
    k = WelchKernel(s, nt)
    j = 37
    lines = np.zeros(nt // 2 + 1)
    lines[j] = 1.0
    t = np.arange(n) * dt
    e = np.exp(2j * np.pi * j / (nt * dt) * t)
    expected = np.zeros(n // 2 + 1)
    for sign in (1, -1):  # the line and its conjugate partner, each of variance 1
        v = (e if sign > 0 else e.conj())
        expected += s.scale * np.abs(np.fft.fft(s.window * (v - v.mean()))[: n // 2 + 1]) ** 2
    np.testing.assert_allclose(k.apply(lines), expected, rtol=1e-9, atol=1e-12)


def test_kernel_of_white_lines_is_flat():
    nt, n, dt = 4096, 256, 0.5
    k = WelchKernel(WelchSetup(n, dt), nt)
    lines = np.full(nt // 2 + 1, 1.0 / nt)  # variance 1 over the band: one-sided PSD 2 dt
    lines[0] = 0.0
    out = k.apply(lines)
    np.testing.assert_allclose(out[3:-1], 2 * dt, rtol=1e-5)
    # mean removal: E|X_m|^2 = sum w^2 - |W(m/n)|^2 / n, i.e. 5/6 of the flat level at bin 1 (Hann), and
    # (dt/3) / (2 dt) = 1/6 at bin 0; lines beyond KERNEL_BAND bins carry the rest (the mean term decays as 1/f)
    assert out[1] / (2 * dt) == pytest.approx(5 / 6, rel=2e-3)
    assert out[0] / (2 * dt) == pytest.approx(1 / 6, rel=2e-2)


@pytest.mark.parametrize("g", [0.0, 0.3, 0.9])
def test_coherence_stats_match_closed_forms(g):
    n = 50.0
    st = coherence_stats(np.sqrt(g) + 0j, n)
    # Var coh2 = 2 g (1-g)^2 / n (+ bias^2), Var cocoh = (1 - c^2)^2 / (2n), Var phase = (1-g)/(2 n g),
    # each plus the float32 resolution floor
    fl = COHERENCE_FLOOR**2
    assert st["coh2_sd"] ** 2 == pytest.approx(2 * g * (1 - g) ** 2 / n + ((1 - g) ** 2 / n) ** 2 + fl, rel=1e-9)
    assert st["cocoh_sd"] ** 2 == pytest.approx((1 - g) ** 2 / (2 * n) + fl, rel=1e-9)
    if g > 0:
        assert st["phase_sd"] ** 2 == pytest.approx((1 - g) / (2 * n * g) + fl, rel=1e-9)
    assert st["coh2_mean"] == pytest.approx(g + (1 - g) ** 2 / n)


def test_coherence_stats_against_monte_carlo():
    # n independent complex Gaussian pairs with coherency rho: sample mean/sd of the estimators
    rng = np.random.default_rng(7)
    rho, n, trials = 0.6 * np.exp(0.5j), 40, 4000
    a = (rng.standard_normal((trials, n)) + 1j * rng.standard_normal((trials, n))) / np.sqrt(2)
    b = (rng.standard_normal((trials, n)) + 1j * rng.standard_normal((trials, n))) / np.sqrt(2)
    y = np.conj(rho) * a + np.sqrt(1 - abs(rho) ** 2) * b  # E[conj(a) y] = rho
    c = np.mean(np.conj(a) * y, axis=1)
    aa, yy = np.mean(abs(a) ** 2, axis=1), np.mean(abs(y) ** 2, axis=1)
    coh2, cocoh = abs(c) ** 2 / (aa * yy), c.real / np.sqrt(aa * yy)
    st = coherence_stats(rho, n)
    # Monte Carlo sd of a sd estimate ~ 1/sqrt(2 trials) ~ 1.1 %; the delta method is O(1/n): allow 10 %
    assert coh2.std() == pytest.approx(st["coh2_sd"], rel=0.10)
    assert cocoh.std() == pytest.approx(st["cocoh_sd"], rel=0.10)
    assert np.std(np.angle(c)) == pytest.approx(st["phase_sd"], rel=0.10)
    # the mean coh2 including the bias, within 4 standard errors of the Monte Carlo mean
    assert abs(coh2.mean() - st["coh2_mean"]) < 4 * coh2.std() / np.sqrt(trials)


def test_pair_counts():
    c = rect_pair_counts(4, 3, 4, 3)
    assert c.sum() == (4 * 3) ** 2 and c[3, 2] == 12
    iy, iz = np.array([0, 2]), np.array([1])
    s = set_pair_counts(4, 3, iy, iz)
    assert s.sum() == 4 and s[3, 2] == 2 and s[5, 2] == 1


def test_spans_use_whole_chunks_and_enough_segments():
    spans = plan_spans(4096, 1024, 512)
    assert spans == [(0, 2048), (2048, 4096)]
    # memory cap: 64 x 64 points, u v w float32 = 48 KiB per step; 4 segments of 4096 would need 768 MiB
    assert plan_spans(65536, 1024, 4096, 3 * 4 * 64 * 64)[0] == (0, 6144)
    assert plan_spans(1000, 128, 64) == [(0, 256), (256, 512), (512, 768), (768, 1000)]
    assert default_nperseg(4096) == 512
    with pytest.raises(ParameterError):
        default_nperseg(100)


def test_rotor_and_separations():
    g = Grid(nt=256, dt_s=0.5, x_m=(0.0,), ny=16, nz=16, dy_m=8.0, dz_m=8.0)
    m = rotor_mask(g, 30.0)
    y, z = g.y(), g.z()
    assert m.sum() == np.sum(y[:, None] ** 2 + z[None, :] ** 2 <= 900.0)
    with pytest.raises(ParameterError, match="rotor radius"):
        check_rotor_radius(g, 61.0)
    assert default_separations(g) == ((1, 0), (4, 0), (0, 1), (0, 4), (2, 2))


def test_kaimal_rews_lines_equal_eq25_of_the_theory_module():
    # two independent implementations of Guo et al. (2023), Eq. 25 over the grid's rotor points
    from turbgen.spec.kaimal import KaimalRun, kaimal_params
    from turbgen.theory.kaimal import kaimal_spectrum
    from turbgen.theory.rotor_effective import rews_spectrum_kaimal
    from turbgen.store.layout import grid_to_attrs
    from turbgen.validation.kaimal_expectation import kaimal_theory
    from turbgen.validation.prediction import SamplingDesign

    g = Grid(nt=512, dt_s=0.5, x_m=(0.0, 30.0), ny=12, nz=10, dy_m=7.0, dz_m=9.0)
    run = KaimalRun(kaimal=kaimal_params(14.0, "A", 90.0), grid=g, U_m_s=14.0, seed=1)
    mask = rotor_mask(g, 35.0)
    setup = WelchSetup(64, g.dt_s)
    design = SamplingDesign(g, setup, default_separations(g), mask, np.arange(12), np.arange(10))
    th = kaimal_theory({**run.to_attrs(), "grid": grid_to_attrs(run.grid)}, design)  # as the store holds them
    yy, zz = np.meshgrid(g.y(), g.z(), indexing="ij")
    j = np.array([1, 5, 40, 200])
    ref = rews_spectrum_kaimal(th.line_f[j], run.kaimal, 14.0, yy[mask], zz[mask])
    # the lines are bin integrals of S_1 (``kaimal_expectation``); Eq. 25's rotor factor S_RR / S_1 is per line
    s1 = kaimal_spectrum(th.line_f[j], run.kaimal.sigma_m_s[0], run.kaimal.length_scales_m[0], 14.0)
    np.testing.assert_allclose(th.rews[j] / th.auto["u"][j], ref / s1, rtol=1e-9)
