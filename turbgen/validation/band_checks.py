"""Statistics of band-pooled Welch estimates: Welch bins grouped into log-spaced bands, and the normal score of each
band's spectrum (gamma law) and coherence (Goodman's and the Rice phase law) comparison (``verdict`` explains)."""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2, norm

from turbgen.validation.checks import Check
from turbgen.validation.distributions import coh2_z, phase_z
from turbgen.validation.estimators import Estimates
from turbgen.validation.welch_variance import MAX_LAG, WelchCovariance

BANDS_PER_DECADE = 5
COHERENCE_FLOOR = 1e-5  # absolute resolution of a coherence estimated from float32 data
NEAR_UNIT = 1e-3  # 1 - |rho|^2 below this: delta method with the float32 floor (frozen planes), not the exact laws


def chi2_z(ratio, nu):
    """Normal score [-] of an observed ``ratio`` under ratio ~ chi2_nu / nu (two-sided tails, equal in probability)."""
    ratio, nu = np.asarray(ratio, float), np.asarray(nu, float)
    lower = chi2.logcdf(nu * ratio, nu)
    upper = chi2.logsf(nu * ratio, nu)
    return np.where(lower < upper, norm.ppf(np.exp(lower)), norm.isf(np.exp(upper)))


def coherence_stats(rho, n):
    """Delta-method mean and sd [-] of coh2 and cocoh and sd of the phase [rad] from ``n`` independent samples of
    coherency ``rho``, the sds kept above COHERENCE_FLOOR (float32 resolution)."""
    rho = np.asarray(rho, complex)
    n = np.asarray(n, float)
    g = np.abs(rho) ** 2
    re, im = rho.real, rho.imag
    r2c = rho * rho
    # per-sample covariance of (A, B, Re C, Im C), unit auto-spectra (Isserlis, circular Gaussian)
    cov = np.empty(rho.shape + (4, 4))
    cov[..., 0, 0] = cov[..., 1, 1] = 1.0
    cov[..., 0, 1] = cov[..., 1, 0] = g
    for i in (0, 1):
        cov[..., i, 2] = cov[..., 2, i] = re
        cov[..., i, 3] = cov[..., 3, i] = im
    cov[..., 2, 2] = (1.0 + r2c.real) / 2.0
    cov[..., 3, 3] = (1.0 - r2c.real) / 2.0
    cov[..., 2, 3] = cov[..., 3, 2] = r2c.imag / 2.0

    def var(grad):
        grad = np.stack(np.broadcast_arrays(*grad), axis=-1)
        return np.einsum("...i,...ij,...j->...", grad, cov, grad) / n

    zero = np.zeros_like(g)
    bias = (1.0 - g) ** 2 / n
    coh2_var = var((-g, -g, 2 * re, 2 * im)) + bias**2
    cocoh_var = var((-re / 2, -re / 2, 1.0 + zero, zero))
    with np.errstate(divide="ignore", invalid="ignore"):
        phase_var = np.where(g > 0, var((zero, zero, -im / g, re / g)), np.inf)
    # float32 data: coherences of identical signals (frozen planes) are 1 only to ~1e-6; keep sd above that
    floor = COHERENCE_FLOOR**2
    return {
        "coh2_mean": g + bias,
        "coh2_sd": np.sqrt(coh2_var + floor),
        "cocoh_mean": re,
        "cocoh_sd": np.sqrt(cocoh_var + floor),
        "phase_sd": np.minimum(np.sqrt(phase_var + floor), np.pi / np.sqrt(3.0)),  # uniform phase at most
    }


class Bands:
    """Welch bins 1 .. n/2-1 grouped into log-spaced bands; band statistics from the Welch covariance, a dict
    lag d -> Cov(P_m, P_{m+d}): exact (``welch_variance``) or, for very long records, the rule of thumb with Hann bin
    correlations 1, 4/9, 1/36."""

    def __init__(self, est: Estimates):
        f = est.freqs
        self.bins = np.arange(1, f.size - 1)
        fb = f[self.bins]
        n_edges = max(2, int(np.ceil(np.log10(fb[-1] / fb[0]) * BANDS_PER_DECADE)) + 1)
        edges = np.geomspace(fb[0], fb[-1] * (1 + 1e-9), n_edges)
        idx = np.clip(np.searchsorted(edges, fb, side="right") - 1, 0, n_edges - 2)
        self.groups = [self.bins[idx == k] for k in range(n_edges - 1) if np.any(idx == k)]
        self.f = f
        self.lag_corr = {0: 1.0, 1: est.setup.bin_rho2(1), 2: est.setup.bin_rho2(2)}
        self.k_eff = est.effective_segments

    def cov(self, wcov: WelchCovariance, lines: np.ndarray, expected: np.ndarray) -> dict:
        """One-point covariance dict of the Welch estimate of ``lines`` (expected estimate ``expected``)."""
        exact = wcov.cov(lines)
        if exact is not None:
            return exact
        e = np.asarray(expected, float)
        return {d: e[: e.size - d] * e[d:] * self.lag_corr.get(d, 0.0) / self.k_eff for d in range(MAX_LAG + 1)}

    def averaged_cov(self, wcov: WelchCovariance, terms, one_point: dict, rho2: np.ndarray, rho: np.ndarray) -> dict:
        """Covariance dict of the point-averaged estimate: exact from ``terms`` (``WelchCovariance.node_terms``) and the
        two-frequency sum ``rho2``; else the ``one_point`` covariance times sqrt(rho_m rho_m') (``rho`` per bin)."""
        exact = wcov.averaged(terms, rho2)
        if exact is not None:
            return exact
        r = np.sqrt(np.asarray(rho, float))
        return {d: c * r[: r.size - d] * r[d:] for d, c in one_point.items()}

    @staticmethod
    def sum_var(cov: dict, group: np.ndarray) -> float:
        """Variance of the sum over the bins ``group`` of an estimate with covariance dict ``cov``."""
        total = 0.0
        for d, c in cov.items():
            a = group[group + d <= group[-1]]
            part = np.sum(c[a])
            total += part if d == 0 else 2.0 * part
        return float(total)

    def spectrum_checks(self, label, est, exp, cov) -> list[Check]:
        """Band means of a point-averaged Welch spectrum: ratio ~ chi2_nu / nu, nu = 2 E^2 / Var (gamma law
        with the exact mean and variance; Welch 1967 / Satterthwaite equivalent degrees of freedom)."""
        out = []
        for g in self.groups:
            e, x = float(np.mean(est[g])), float(np.mean(exp[g]))
            s = np.sqrt(self.sum_var(cov, g)) / g.size
            z = float(chi2_z(e / x, 2.0 * (x / s) ** 2)) if x > 0 and s > 0 else 0.0
            out.append(Check(label, (float(self.f[g[0]]), float(self.f[g[-1]])), e, x, float(s), z))
        return out

    def coherence_checks(self, label, cross, auto_a, auto_b, rho_lines, exp_auto, cov) -> list[Check]:
        """Exact-law tests of the band-pooled sample coherency C = sum_g cross / sqrt(sum_g A sum_g B).

        E C = rho_band = sum_g rho_m E_m / sum_g E_m, from n_band = (sum_g E_m)^2 / Var(sum_g A) samples: Goodman's
        and the Rice phase law (``distributions``); near unit coherence (1 - |rho|^2 < NEAR_UNIT) the delta method."""
        gs = self.groups
        c, a, b, e_sum = (np.array([np.sum(v[g]) for g in gs]) for v in (cross, auto_a, auto_b, exp_auto))
        rho_band = np.array([np.sum(rho_lines[g] * exp_auto[g]) for g in gs]) / e_sum
        n_band = e_sum**2 / np.array([self.sum_var(cov, g) for g in gs])
        coh = c / np.sqrt(a * b)
        gam2 = np.minimum(np.abs(rho_band) ** 2, 1.0)
        dphi = wrap_phase(np.angle(coh) - np.angle(rho_band))
        st = coherence_stats(rho_band, n_band)
        near = 1.0 - gam2 < NEAR_UNIT
        g_exact = np.where(near, 0.5, gam2)  # (placeholder where the delta method is used)
        z_coh = np.where(near, (np.abs(coh) ** 2 - st["coh2_mean"]) / st["coh2_sd"], coh2_z(np.abs(coh) ** 2, g_exact,
                                                                                              n_band))
        z_ph = np.where(near, dphi / st["phase_sd"], phase_z(dphi, g_exact, n_band))
        out = []
        for i, g in enumerate(gs):
            band = (float(self.f[g[0]]), float(self.f[g[-1]]))
            out.append(Check(f"coh2 {label}", band, float(abs(coh[i]) ** 2), float(st["coh2_mean"][i]),
                            float(st["coh2_sd"][i]), float(z_coh[i])))
            out.append(Check(f"phase {label}", band, float(np.angle(coh[i])), float(np.angle(rho_band[i])),
                            float(st["phase_sd"][i]), float(z_ph[i])))
        return out


def wrap_phase(a):
    """Angle(s) ``a`` [rad] wrapped to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi
