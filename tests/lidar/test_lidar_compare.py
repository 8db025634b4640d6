"""The lidar coherence verdict on series of known coherence (no field, no lidar theory needed)."""

import numpy as np

from turbgen.virtual_lidar import compare, signals
from turbgen.validation.estimators import WelchSetup


def pair(coh2, n, seed):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal(n)
    b = np.sqrt(coh2) * a + np.sqrt(1 - coh2) * rng.standard_normal(n)
    return a, b


def test_known_coherence_passes_and_a_wrong_theory_fails():
    setup = WelchSetup(64, 1.0)
    a, b = pair(0.7, 64 * 200, seed=3)
    w = signals.welch_rl(a, b, setup)
    assert w["n_eff"] > 300  # 399 half-overlapping segments
    ok = compare.coherence_metric(w["f_hz"], w["coh2_RL"], np.full(w["f_hz"].size, 0.7), w["n_eff"])
    assert len(ok.checks) == 31 and ok.passed, ok.max_abs_z
    # theory 0.55 instead of 0.7: sd of coh2 = sqrt(2 g (1-g)^2 / n_eff) ~ 0.02-0.03, bins ~ 5-7 sd off
    bad = compare.coherence_metric(w["f_hz"], w["coh2_RL"], np.full(w["f_hz"].size, 0.55), w["n_eff"])
    assert not bad.passed
    # |G_RL| = |S_RL| / S_LL = sqrt(0.7) for b = sqrt(0.7) a + noise
    np.testing.assert_allclose(np.median(w["G_RL"][1:-1]), np.sqrt(0.7), atol=0.03)


def test_preview_numbers_on_analytic_curves():
    f = np.linspace(0, 1, 1001)
    coh2 = np.exp(-f / 0.1)  # gamma^2 = 0.5 at f = 0.1 ln 2
    gain = 1 / np.sqrt(1 + (f / 0.05) ** 2)  # -3 dB at 0.05 Hz
    out = compare.preview_numbers(f, coh2, gain, 16.0)
    np.testing.assert_allclose(out["k05_rad_m"], 2 * np.pi * 0.1 * np.log(2) / 16.0, rtol=1e-4)
    np.testing.assert_allclose(out["cutoff_hz"], 0.05, rtol=1e-4)
    np.testing.assert_allclose(out["d_eddy_min_m"], 2 * np.pi / out["k05_rad_m"])
    assert compare.crossing(f, np.ones_like(f), 0.5) is None
