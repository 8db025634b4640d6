"""Simulated lidar-rotor coherence against theory, with the verdict machinery of ``turbgen validate``.

The simulated gamma^2_RL is a Welch estimate from n_eff effectively independent segments
(``WelchSetup.effective_segments``; several seeds add their n_eff). Its mean and standard deviation
under the null hypothesis "the field follows the theory" come from
``turbgen.validate.band_checks.coherence_stats`` (delta method, including the (1 - g)^2/n bias), each
bin giving a normal score z; the family of bins fails at |z| > z_crit (Bonferroni, ALPHA of the
validator), exactly as a validator metric. Bins are compared only where the theory gives
gamma^2 >= MIN_COH2 and n_eff >= MIN_NEFF: below that the estimator's law is far from Gaussian
(Beta(1, n-1) at zero coherence) and the first-order delta method does not hold. At the other end,
gamma^2 ~ 0.95 in the lowest bin, the estimator's law is skewed to low values: for 4 fields of 512 s
(n_eff 53) a Monte-Carlo of the estimator puts 0.37 % of ensembles below z = -3.80 (0.007 % for a normal z)
and its sd 14 % above the delta method's, so that bin false-alarms more often than ALPHA (issue 12).
"""

from __future__ import annotations

import numpy as np

from turbgen.validate.band_checks import coherence_stats
from turbgen.validate.checks import Check, Curve, MetricResult

MIN_COH2 = 0.2
MIN_NEFF = 10.0


def coherence_metric(f_hz, coh2_sim, coh2_theory, n_eff: float, f_max_hz: float | None = None,
                     f_min_hz: float | None = None) -> MetricResult:
    """MetricResult comparing simulated and theoretical gamma^2_RL bin by bin (bins 1 .. Nyquist-1).

    Bins are tested where the theory gives gamma^2 >= MIN_COH2 and f_min_hz <= f <= ``f_max_hz``, and only if
    n_eff >= MIN_NEFF; each tested bin's z uses the delta-method mean and sd of
    ``turbgen.validate.band_checks.coherence_stats``.

    Parameters
    ----------
    f_hz : array_like
        Welch bin frequencies [Hz], 0 .. Nyquist.
    coh2_sim : array_like
        Simulated magnitude-squared coherence gamma^2_RL [-], one value per bin.
    coh2_theory : array_like
        Theoretical gamma^2_RL [-], one value per bin (clipped to [0, 1]).
    n_eff : float
        Effective number of independent Welch segments [-].
    f_max_hz : float, optional
        Highest frequency tested [Hz]; None (default) tests up to Nyquist-1.
    f_min_hz : float, optional
        Lowest frequency tested [Hz]; None (default) tests from bin 1 (where the normal z's tail is too
        light at gamma^2 ~ 0.95, see the module docstring).

    Returns
    -------
    MetricResult
        Metric "lidar_coherence": one Check per tested bin and the curve with its 95 % band
        (mean +- 1.96 sd).
    """
    f = np.asarray(f_hz, float)
    sim = np.asarray(coh2_sim, float)
    th = np.clip(np.asarray(coh2_theory, float), 0.0, 1.0)
    st = coherence_stats(np.sqrt(th), n_eff)
    mean, sd = st["coh2_mean"], st["coh2_sd"]
    sel = np.zeros(f.size, bool)
    sel[1:-1] = True
    sel &= th >= MIN_COH2
    if f_max_hz is not None:
        sel &= f <= f_max_hz
    if f_min_hz is not None:
        sel &= f >= f_min_hz
    if n_eff < MIN_NEFF:
        sel[:] = False
    checks = [Check("coh2_RL", (float(f[i]), float(f[i])), float(sim[i]), float(mean[i]), float(sd[i]),
                  float((sim[i] - mean[i]) / sd[i])) for i in np.nonzero(sel)[0]]
    curve = Curve("coh2_RL", f[1:-1], sim[1:-1], mean[1:-1], (mean - 1.96 * sd)[1:-1], (mean + 1.96 * sd)[1:-1])
    return MetricResult("lidar_coherence", "lidar-rotor coherence gamma^2_RL", "coh2 (-)", checks, [curve])


def crossing(f_hz, values, level: float) -> float | None:
    """First frequency [Hz] where ``values`` falls below ``level`` (linear interpolation), None if never.

    Bin 0 is skipped; non-finite values never count as a crossing.

    Parameters
    ----------
    f_hz : array_like
        Frequencies [Hz], increasing.
    values : array_like
        Curve sampled at ``f_hz`` (e.g. gamma^2_RL or |G_RL|) [-].
    level : float
        Level to cross [-], in the units of ``values``.

    Returns
    -------
    float or None
        Crossing frequency [Hz]; ``f_hz[1]`` if bin 1 is already below; None if the curve never falls below.
    """
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
    """MCB k_0.5 [rad/m], d_eddy,min [m] and the -3 dB cut-off of |G_RL| [Hz] of one set of curves.

    k_0.5 = 2 pi f_0.5 / U where gamma^2 = 0.5 (Guo et al. 2024 Eq. 26), d_eddy,min = 2 pi / k_0.5, and
    the cut-off is where |G_RL| = 1/sqrt 2.

    Parameters
    ----------
    f_hz : array_like
        Frequencies [Hz], increasing (bin 0 is skipped, see :func:`crossing`).
    coh2 : array_like
        gamma^2_RL [-] at ``f_hz``.
    gain : array_like
        |G_RL| [-] at ``f_hz``.
    U_m_s : float
        Mean wind speed U [m/s].

    Returns
    -------
    dict
        ``k05_rad_m`` [rad/m], ``d_eddy_min_m`` [m] and ``cutoff_hz`` [Hz]; each None where its curve
        never crosses its level.
    """
    f05 = crossing(f_hz, coh2, 0.5)
    fc = crossing(f_hz, gain, 1.0 / np.sqrt(2.0))
    k05 = None if f05 is None else 2 * np.pi * f05 / U_m_s
    return {"k05_rad_m": k05, "d_eddy_min_m": None if k05 is None else 2 * np.pi / k05, "cutoff_hz": fc}
