"""Simulated lidar-rotor coherence against theory, with the verdict machinery of ``turbgen validate``.

Under the null hypothesis each bin's Welch gamma^2_RL follows Goodman's law of the sample coherence of n
independent segments (Goodman 1963; Carter, Knapp & Nuttall 1973), n from ``welch_expectation.effective_segments``;
a bin fails at |z| > z_crit (Bonferroni). Bins are compared only where gamma^2 >= MIN_COH2 and n >= MIN_NEFF, where
a Monte-Carlo calibrated the law (docs/lidar.md, "Verdict")."""

from __future__ import annotations

import numpy as np

from turbgen.validation.band_checks import NEAR_UNIT, coherence_stats
from turbgen.validation.checks import Check, Curve, MetricResult
from turbgen.validation.distributions import coh2_moments, coh2_quantile, coh2_z

MIN_COH2 = 0.2
MIN_NEFF = 10.0
BAND_P = (0.025, 0.975)  # probabilities of the plotted band's edges


def coherence_metric(f_hz, coh2_sim, coh2_theory, n_eff) -> MetricResult:
    """MetricResult "lidar_coherence" of simulated vs theoretical gamma^2_RL [-] at ``f_hz`` [Hz] (0 .. Nyquist):
    bins 1 .. Nyquist-1 where gamma^2 >= MIN_COH2 and ``n_eff`` >= MIN_NEFF are tested by Goodman's law, or by the
    delta method where 1 - gamma^2 < NEAR_UNIT or n_eff <= 1."""
    f = np.asarray(f_hz, float)
    sim = np.asarray(coh2_sim, float)
    th = np.clip(np.asarray(coh2_theory, float), 0.0, 1.0)
    n = np.broadcast_to(np.asarray(n_eff, float), f.shape)
    exact = (1.0 - th >= NEAR_UNIT) & (n > 1.0)
    g, ne = np.where(exact, th, 0.5), np.where(exact, n, 2.0)  # (placeholders where the delta method is used)
    st = coherence_stats(np.sqrt(th), n)
    mean_x, sd_x = coh2_moments(g, ne)
    mean = np.where(exact, mean_x, st["coh2_mean"])
    sd = np.where(exact, sd_x, st["coh2_sd"])
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(exact, coh2_z(sim, g, ne), (sim - mean) / sd)
    lower, upper = (np.where(exact, coh2_quantile(p, g, ne), mean + np.sign(p - 0.5) * 1.96 * sd) for p in BAND_P)
    sel = np.zeros(f.size, bool)
    sel[1:-1] = True
    sel &= (th >= MIN_COH2) & (n >= MIN_NEFF)
    checks = [Check("coh2_RL", (float(f[i]), float(f[i])), float(sim[i]), float(mean[i]), float(sd[i]), float(z[i]))
              for i in np.nonzero(sel)[0]]
    curve = Curve("coh2_RL", f[1:-1], sim[1:-1], mean[1:-1], lower[1:-1], upper[1:-1])
    return MetricResult("lidar_coherence", "lidar-rotor coherence gamma^2_RL", "coh2 (-)", checks, [curve])


def crossing(f_hz, values, level: float) -> float | None:
    """First frequency [Hz] past bin 0 where ``values`` falls below ``level`` (linear interpolation); None if never."""
    f, v = np.asarray(f_hz, float), np.asarray(values, float)
    below = np.nonzero((v[1:] < level) & np.isfinite(v[1:]))[0]
    if below.size == 0:
        return None
    i = below[0] + 1
    if i == 1:
        return float(f[1])
    a = (v[i - 1] - level) / (v[i - 1] - v[i])
    return float(f[i - 1] + a * (f[i] - f[i - 1]))


def preview_numbers(f_hz, coh2, gain, U_m_s: float) -> dict:
    """MCB k_0.5 [rad/m] (gamma^2 = 0.5, Guo et al. 2024 Eq. 26), d_eddy,min = 2 pi / k_0.5 [m] and the
    -3 dB cut-off of |G_RL| [Hz] of one set of curves; each None where its curve never crosses."""
    f05 = crossing(f_hz, coh2, 0.5)
    fc = crossing(f_hz, gain, 1.0 / np.sqrt(2.0))
    k05 = None if f05 is None else 2 * np.pi * f05 / U_m_s
    return {"k05_rad_m": k05, "d_eddy_min_m": None if k05 is None else 2 * np.pi / k05, "cutoff_hz": fc}
