"""Goodman's law of the Welch gamma^2_RL behind the lidar verdict: moments, quantiles, per-bin segments, calibration."""

import numpy as np
import pytest
from scipy.special import hyp2f1
from scipy.stats import norm

from turbgen.virtual_lidar import compare, signals
from turbgen.virtual_lidar.welch_expectation import effective_segments, weigh_lines
from turbgen.validation.distributions import coh2_moments, coh2_quantile, coh2_tails, coh2_z
from turbgen.validation.estimators import WelchSetup, segment_starts
from turbgen.validation.welch_kernel import WelchKernel
from turbgen.validation.welch_variance import WelchCovariance


def _segment_coherence(rng, g2, n, trials):
    """Sample magnitude-squared coherence of n independent circular Gaussian pairs with coherence g2."""
    x = (rng.standard_normal((trials, n)) + 1j * rng.standard_normal((trials, n))) / np.sqrt(2)
    e = (rng.standard_normal((trials, n)) + 1j * rng.standard_normal((trials, n))) / np.sqrt(2)
    y = np.sqrt(g2) * np.exp(0.7j) * x + np.sqrt(1 - g2) * e
    return np.abs((np.conj(x) * y).sum(1)) ** 2 / ((np.abs(x) ** 2).sum(1) * (np.abs(y) ** 2).sum(1))


@pytest.mark.parametrize("g2, n", [(0.95, 42), (0.95, 12), (0.6, 20)])
def test_law_matches_independent_segments(g2, n):
    rng = np.random.default_rng(5)
    T = 100_000
    c = _segment_coherence(rng, g2, n, T)
    # the law's tails at the Monte-Carlo quantiles: the fraction of T trials below a quantile has the
    # binomial sd sqrt(p (1 - p) / T); 5 sd plus 1e-4 for the quadrature of the tails
    p = np.array([0.001, 0.025, 0.5, 0.975, 0.999])
    lower, upper = coh2_tails(np.quantile(c, p), g2, n)
    tol = 5 * np.sqrt(p * (1 - p) / T) + 1e-4
    assert np.all(np.abs(lower - p) <= tol) and np.all(np.abs(upper - (1 - p)) <= tol), (lower, upper)
    # moments: the MC mean has sd s / sqrt(T); the MC sd has sd sqrt(m4 - s^4) / (2 s sqrt(T)) (delta method)
    mean, sd = coh2_moments(g2, n)
    s, m4 = c.std(), np.mean((c - c.mean()) ** 4)
    assert abs(c.mean() - mean) <= 5 * s / np.sqrt(T), (c.mean(), mean)
    assert abs(s - sd) <= 5 * np.sqrt(m4 - s**4) / (2 * s * np.sqrt(T)), (s, sd)
    # quantile inverts the tails
    q = coh2_quantile(p, g2, n)
    np.testing.assert_allclose(coh2_tails(q, g2, n)[0], p, rtol=1e-7)


def test_law_limits_and_closed_forms():
    # gamma2 = 0: Beta(1, n - 1), real n
    n = np.array([3.0, 10.5, 200.0])
    mean, sd = coh2_moments(0.0, n)
    np.testing.assert_allclose(mean, 1 / n, rtol=1e-10)
    np.testing.assert_allclose(sd, np.sqrt((n - 1) / (n**2 * (n + 1))), rtol=1e-8)
    p = np.array([0.01, 0.5, 0.99])
    np.testing.assert_allclose(coh2_quantile(p, 0.0, 10.5), 1 - (1 - p) ** (1 / 9.5), rtol=1e-8)
    # E G = 1 - (n-1)(1-g)/n 2F1(1,1;n+1;g), E (1-G)^2 = (n-1)(1-g) (2F1(1,1;n+1;g) - n/(n+1) 2F1(1,2;n+2;g))
    # (Carter, Knapp & Nuttall 1973 series summed), where scipy's 2F1 is accurate
    for g2, m in ((0.5, 20.5), (0.9, 30.0), (0.3, 7.0)):
        f1, f2 = hyp2f1(1, 1, m + 1, g2), hyp2f1(1, 2, m + 2, g2)
        h1 = (m - 1) * (1 - g2) / m * f1
        h2 = (m - 1) * (1 - g2) * (f1 - m / (m + 1) * f2)
        mean, sd = coh2_moments(g2, m)
        np.testing.assert_allclose([mean, sd], [1 - h1, np.sqrt(h2 - h1**2)], rtol=1e-9)
    # large n: E G - gamma2 -> (1 - gamma2)^2 / n, sd -> the delta method's sqrt(2 g (1 - g)^2 / n)
    mean, sd = coh2_moments(0.8, 1e5)
    np.testing.assert_allclose(mean - 0.8, 0.04 / 1e5, rtol=1e-3)
    np.testing.assert_allclose(sd, np.sqrt(2 * 0.8 * 0.04 / 1e5), rtol=1e-3)


def test_law_is_monotone():
    # tails and normal score over the whole range (the lower tail down to ~1e-16, the Gauss-Hermite quadrature's
    # floor: no nan where the noncentral F cdf underflows), strictly monotone where |z| < 7
    g = np.linspace(0.5, 0.999, 400)
    lower, upper = coh2_tails(g, 0.9, 42.0)
    assert np.all(np.isfinite(lower)) and np.all(np.diff(lower) >= 0) and np.all(np.diff(upper) <= 0)
    z = coh2_z(g, 0.9, 42.0)
    assert z[0] < -7 and z[-1] > 7 and np.all(np.diff(z[np.abs(z) < 7]) > 0)
    q = coh2_quantile(norm.cdf(np.linspace(-6, 6, 61)), 0.95, 53.25)
    assert np.all(np.diff(q) > 0)
    mean, sd = coh2_moments(np.linspace(0, 0.998, 200), 42.0)
    assert np.all(np.diff(mean) > 0)


def test_metric_z_is_the_laws_normal_score():
    f = np.arange(34) / 64.0
    th = np.linspace(0.98, 0.1, f.size)
    n = np.linspace(40.0, 55.0, f.size)
    mean, _ = coh2_moments(th, n)
    at_mean = compare.coherence_metric(f, mean, th, n)
    # mean and median differ by a fraction of an sd: |z| < 0.2 (skew of the law / 6)
    assert at_mean.passed and len(at_mean.checks) == np.sum(th[1:-1] >= compare.MIN_COH2) and at_mean.max_abs_z < 0.2
    for t in (-3.0, 2.5):
        z = [c.z for c in compare.coherence_metric(f, coh2_quantile(norm.cdf(t), th, n), th, n).checks]
        np.testing.assert_allclose(z, t, atol=1e-6)
    m = compare.coherence_metric(f, coh2_quantile(norm.cdf(-(at_mean.z_crit + 0.2)), th, n), th, n)
    assert not m.passed
    # the plotted band is the law's 2.5 / 97.5 % quantiles
    np.testing.assert_allclose(m.curves[0].lower, coh2_quantile(0.025, th, n)[1:-1], rtol=1e-9)
    # unit theory coherence (frozen planes) falls back to the delta method, finite
    assert np.isfinite(compare.coherence_metric(f, np.ones(f.size), np.ones(f.size), 50.0).max_abs_z)


def test_effective_segments_match_the_exact_welch_covariance():
    # independent implementation: turbgen.validation.welch_variance (E^2 / Var of one point's Welch estimate)
    setup, nt = WelchSetup(64, 1.0), 1024
    lines = np.arange(1, nt // 2) / nt
    S = 1 / (1 + (lines / 0.01) ** 2) ** (5 / 6)
    bins = np.arange(1, 20) / 64
    L = np.zeros(nt // 2 + 1)
    L[1 : nt // 2] = S
    ref = WelchKernel(setup, nt).apply(L) ** 2 / WelchCovariance(setup, nt, segment_starts(nt, setup)).cov(L)[0]
    np.testing.assert_allclose(effective_segments(S, S, lines, bins, setup, nt), ref[1:20], rtol=1e-3)
    # white lines: the rule of thumb (Welch 1967) away from bin 1, fewer segments in bin 1
    k = len(segment_starts(nt, setup))
    white = effective_segments(np.ones(lines.size), 2 * np.ones(lines.size), lines, bins, setup, nt)
    np.testing.assert_allclose(white[1:], setup.effective_segments(k, k - 1), rtol=1e-6)
    assert white[0] < 0.85 * white[1]


@pytest.mark.slow
def test_verdict_is_calibrated_on_welch_estimates_of_a_red_coherent_pair():
    # 4000 ensembles of 2 records (1024 samples, 64-sample Hann segments through signals.welch_rl) of a red pair
    # whose coherence is ~0.93 in the lowest bin: the law's normal score (the metric's z, see
    # test_metric_z_is_the_laws_normal_score) of bins 1-4 with the per-bin segments must have mean 0 (sd of the
    # MC mean 1/sqrt(R)), sd 1 (sd of the MC sd ~ 1/sqrt(2R) for a normal z) and the normal |z| > 2.5 fraction
    # (binomial sd), each within 5 sd. With the rule of thumb's n_eff instead, bin 1's z has sd ~ 1.1.
    rng = np.random.default_rng(21)
    setup, nt, R, fields = WelchSetup(64, 1.0), 1024, 4000, 2
    lines = np.arange(1, nt // 2) / nt
    S = 1 / (1 + (lines / 0.01) ** 2) ** (5 / 6)
    coh = 0.995 * np.exp(-lines / 0.5)
    bins = np.arange(1, 5) / 64
    rr, ll, rl = weigh_lines(S, S, coh * S, lines, bins, setup, nt * setup.dt_s)
    th = np.abs(rl) ** 2 / (rr * ll)
    n = fields * effective_segments(S, S, lines, bins, setup, nt)
    spec = np.zeros((2, R * fields, nt // 2 + 1), complex)
    a, e = ((rng.standard_normal((R * fields, lines.size)) + 1j * rng.standard_normal((R * fields, lines.size)))
            * np.sqrt(S / 2) for _ in range(2))
    spec[0, :, 1 : nt // 2] = a
    spec[1, :, 1 : nt // 2] = coh * a + np.sqrt(1 - coh**2) * e
    x_r, x_l = np.fft.irfft(spec, nt, axis=-1)
    acc = np.zeros((3, R, 4), complex)
    for i in range(R * fields):
        w = signals.welch_rl(x_l[i], x_r[i], setup)
        acc[:, i // fields] += np.stack([w["S_RR"], w["S_LL"], w["S_RL"]])[:, 1:5]
    z = coh2_z(np.abs(acc[2]) ** 2 / (acc[0].real * acc[1].real), th, n)
    assert th[0] > 0.9 and n[0] < 0.85 * n[1], (th, n)
    assert np.all(np.abs(z.mean(0)) <= 5 / np.sqrt(R)), z.mean(0)
    assert np.all(np.abs(z.std(0) - 1) <= 5 / np.sqrt(2 * R)), z.std(0)
    p = 2 * norm.sf(2.5)
    assert np.all(np.abs((np.abs(z) > 2.5).mean(0) - p) <= 5 * np.sqrt(p * (1 - p) / R)), (np.abs(z) > 2.5).mean(0)
