"""Pass/fail per metric, with tolerances derived from the statistical uncertainty of each estimator.

Null hypothesis: the field is a realisation of the store's model on the store's grid
(``expectations``). Every comparison is turned into a normal score z; a metric fails when any
of its |z| exceeds z_crit = Phi^-1(1 - ALPHA / (2 n)), n the number of comparisons in the
metric (Bonferroni: valid whatever the correlation between the comparisons), so a correct field
fails a given metric with probability <= ALPHA. No fixed fudge factor enters.

Uncertainties (Gaussian fields; derivations in the comments below):
* K_eff: the Welch average of K half-overlapping Hann segments is worth
  K / (1 + 2 rho_w K_adj / K) independent periodograms (Welch 1967), rho_w = 1/36 the
  correlation of overlapping Hann periodograms, K_adj the number of overlapping pairs.
* Averaging over points/planes does not multiply the number of independent samples by the
  number of points: Cov(P_p, P_q) = E P_p E P_q coh2_pq (Isserlis), so the average over a point
  set has relative variance rho_bar / K_eff, rho_bar = mean of the model's coh2 over all ordered
  pairs of the set (``Theory.rho_*``; 1 for fully coherent points, 1/N for independent ones).
  The same holds for averages of cross-products conj(X_p) X_{p+d} over p (their covariance is
  |S_pq|^2 as well). Hence n_eff = K_eff / rho_bar for every averaged estimate.
* Auto-spectra and REWS spectra: ratio estimate/expected ~ chi2_nu / nu, nu = 2 n_eff.
* Variance: one-sided line pair j contributes 2|Z_j|^2 (exponential, variance (2 L_j)^2), so
  Var(sigma^2 estimate) = sum_j (w_j L_j)^2 rho_bar(f_j); compared as chi2 with nu = 2 E^2/Var.
* Coherences from n_eff samples: delta method on (A, B, Re C, Im C) of the estimator
  |C|^2/(A B) (Re C / sqrt(A B), arg C), whose per-sample covariance for circular Gaussian
  amplitudes with complex coherency rho is exact (Isserlis); gives Var coh2 = 2 g(1-g)^2/n,
  Var cocoh = (1 - c^2)^2/(2n), Var phase = (1-g)/(2 n g) at zero quad-coherence, plus the
  bias (1 - g)^2/n of the squared coherence (exact mean 1/n at g = 0, variance 1/n^2 there).
* u-w co-spectrum: Var of the point average <= E_u E_w (sqrt(rho_u rho_w) + rho_uw) / (2 K_eff)
  (Cauchy-Schwarz on the Isserlis covariance; rho_uw the mean |u-w coherency|^2 over pairs).
* Frequency bands: bins are grouped ~5 per decade (mean of the per-bin statistic), with the
  variance of the mean from the Hann inter-bin correlation (4/9 neighbours, 1/36 next).

Approximations, stated: the rho_bar are evaluated at the bin centre (interpolated from
nodes); segments at different times are taken as independent; the delta method is first order
(n_eff >= ~10 in all practical cases: K_eff alone is ~13 for the default 4096 steps).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2, norm

from turbgen.validate.estimators import COMPONENTS, Estimates
from turbgen.validate.expectations import Theory, WelchKernel

ALPHA = 1e-3  # family-wise probability that a correct field fails one given metric
BANDS_PER_DECADE = 5
FLOAT32_FLOOR = 1e-6  # relative resolution of float32 data (tolerance on a mean that is exactly 0)
COHERENCE_FLOOR = 1e-5  # absolute resolution of a coherence estimated from float32 data


@dataclass
class Curve:
    """Per-bin comparison for plots/JSON: estimate with its 95 % band and the expectation."""

    label: str
    f_hz: np.ndarray
    estimate: np.ndarray
    expected: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    reference: tuple | None = None  # (f, values) of the continuous model (plots only)


@dataclass
class Test:
    """One comparison: a frequency band of one curve (or a scalar)."""

    label: str
    band_hz: tuple[float, float] | None
    estimate: float
    expected: float
    sigma: float
    z: float


@dataclass
class MetricResult:
    name: str
    title: str
    quantity: str  # what is compared (units)
    tests: list[Test]
    curves: list[Curve] = field(default_factory=list)
    z_crit: float = 0.0

    def __post_init__(self):
        self.z_crit = float(norm.isf(ALPHA / (2 * max(len(self.tests), 1))))

    @property
    def max_abs_z(self) -> float:
        return max((abs(t.z) for t in self.tests), default=0.0)

    @property
    def passed(self) -> bool:
        return self.max_abs_z <= self.z_crit

    @property
    def worst(self) -> Test | None:
        return max(self.tests, key=lambda t: abs(t.z), default=None)


def _chi2_z(ratio, nu):
    """Normal score of ratio ~ chi2_nu / nu (two-sided tails kept symmetric in probability)."""
    ratio, nu = np.asarray(ratio, float), np.asarray(nu, float)
    lower = chi2.logcdf(nu * ratio, nu)
    upper = chi2.logsf(nu * ratio, nu)
    return np.where(lower < upper, norm.ppf(np.exp(lower)), norm.isf(np.exp(upper)))


def coherence_stats(rho, n):
    """Mean and sd of the coh2, cocoh and phase estimators from n independent samples (module docstring).

    rho: complex coherency; returns dict of arrays coh2_mean, coh2_sd, cocoh_mean, cocoh_sd, phase_sd.
    """
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


class _Bands:
    """Welch bins 1 .. n/2-1 grouped into log-spaced bands; band means with correlated-bin variance."""

    def __init__(self, est: Estimates):
        f = est.freqs
        self.bins = np.arange(1, f.size - 1)
        fb = f[self.bins]
        n_edges = max(2, int(np.ceil(np.log10(fb[-1] / fb[0]) * BANDS_PER_DECADE)) + 1)
        edges = np.geomspace(fb[0], fb[-1] * (1 + 1e-9), n_edges)
        idx = np.clip(np.searchsorted(edges, fb, side="right") - 1, 0, n_edges - 2)
        self.groups = [self.bins[idx == k] for k in range(n_edges - 1) if np.any(idx == k)]
        self.f = f
        rho1, rho2 = est.setup.bin_rho2(1), est.setup.bin_rho2(2)
        self.lag_corr = {0: 1.0, 1: rho1, 2: rho2}

    def mean_sd(self, sd_bins: np.ndarray, group: np.ndarray) -> float:
        s = sd_bins[group]
        lag = np.abs(group[:, None] - group[None, :])
        c = np.vectorize(lambda k: self.lag_corr.get(int(k), 0.0))(lag) if group.size > 1 else np.ones((1, 1))
        return float(np.sqrt(s @ c @ s) / group.size)

    def tests(self, label, est, exp, sd, kind="gauss", transform=None) -> list[Test]:
        """Band tests of per-bin arrays (indexed like the Welch bins).

        kind 'gauss': z = (est - exp)/sd. kind 'chi2': est/exp ~ chi2_nu/nu with nu = 2 (exp/sd)^2, the
        gamma law with the right mean and variance (exact for Welch spectra; for a squared coherence it
        is the exponential law Beta(1, n-1) ~ Exp at zero coherence and Gaussian at high coherence).
        """
        out = []
        for g in self.groups:
            e, x = float(np.mean(est[g])), float(np.mean(exp[g]))
            s = self.mean_sd(sd, g)
            if kind == "chi2":
                z = float(_chi2_z(e / x, 2.0 * (x / s) ** 2)) if x > 0 else 0.0
            else:
                d = e - x if transform is None else transform(e - x)
                z = d / s if s > 0 else (0.0 if d == 0 else np.inf)
            out.append(Test(label, (float(self.f[g[0]]), float(self.f[g[-1]])), e, x, s, float(z)))
        return out


def _band95(est, sd):
    return est - 1.96 * sd, est + 1.96 * sd


def judge(est: Estimates, th: Theory) -> list[MetricResult]:
    """All metrics of the store."""
    kernel = WelchKernel(est.setup, est.grid.nt)
    bands = _Bands(est)
    f = est.freqs
    k_eff = est.effective_segments
    out = [_mean(est, th), *(_variance(est, th, c) for c in COMPONENTS)]
    exp_auto = {c: kernel.apply(th.auto[c]) for c in COMPONENTS}
    for c in COMPONENTS:
        out.append(_spectrum(f"spectrum_{c}", f"one-point spectrum of {c}", est.auto[c], exp_auto[c],
                             th.rho(th.rho_all[c], f) / k_eff, bands, f, th.reference.get(f"spectrum_{c}")))
    for c in COMPONENTS:
        out.append(_yz(est, th, kernel, bands, c, exp_auto[c], k_eff))
    out.append(_longitudinal(est, th, kernel, bands, exp_auto["u"], k_eff))
    out.append(_uw(est, th, kernel, bands, exp_auto, k_eff))
    exp_r = kernel.apply(th.rews)
    out.append(_spectrum("rews_spectrum", f"rotor-effective wind speed spectrum (R = {est.rotor_radius_m:g} m)",
                         est.rews_psd, exp_r, th.rho(th.rho_rews, f) / est.rews_effective_segments, bands, f,
                         th.reference.get("rews_spectrum")))
    return out


def _mean(est: Estimates, th: Theory) -> MetricResult:
    # The grand mean is the average of the j = 0 lines Z_0 (variance L_0 per point); averaging over
    # points can only lower the variance, so sd = sqrt(L_0) is conservative.
    tests = []
    for c in COMPONENTS:
        sd = np.sqrt(th.auto[c][0] + (FLOAT32_FLOOR**2) * th.variance(c))
        tests.append(Test(c, None, est.mean[c], 0.0, float(sd), float(est.mean[c] / sd)))
    return MetricResult("mean", "mean of u, v, w", "m/s", tests)


def _variance(est: Estimates, th: Theory, c: str) -> MetricResult:
    # One-sided line pair j: 2|Z_j|^2 is exponential with variance (2 L_j)^2; the point/plane
    # average multiplies it by rho_bar(f_j). Expected: the lines the grid (Mann: the box lattice) holds.
    lines = th.auto[c][1:] * th.pair_weights[1:]
    var = np.sum(lines**2 * th.rho(th.rho_all[c], th.line_f[1:]))
    e = th.variance(c)
    nu = 2.0 * e * e / var
    z = float(_chi2_z(est.variance[c] / e, nu))
    sd = float(np.sqrt(var))
    t = Test(f"sigma_{c}^2", None, est.variance[c], e, sd, z)
    return MetricResult(f"sigma_{c}", f"variance of {c} (sigma_{c}, TI)", "m^2/s^2", [t])


def _spectrum(name, title, estimate, expected, rel_var, bands: _Bands, f, reference) -> MetricResult:
    # ratio estimate/expected ~ chi2_nu/nu with nu = 2 n_eff, n_eff = K_eff / rho_bar
    sd = expected * np.sqrt(rel_var)
    tests = bands.tests(name.split("_")[-1], estimate, expected, sd, kind="chi2")
    b = bands.bins
    nu = 2.0 / rel_var[b]  # 95 % confidence interval of a chi2_nu/nu estimate (always positive)
    lo, hi = estimate[b] * nu / chi2.ppf(0.975, nu), estimate[b] * nu / chi2.ppf(0.025, nu)
    curve = Curve(name, f[b], estimate[b], expected[b], lo, hi, reference)
    return MetricResult(name, title, "m^2/s^2/Hz", tests, [curve])


def _sep_label(est: Estimates, s) -> str:
    return f"dy={s[0] * est.grid.dy_m:g}m dz={s[1] * est.grid.dz_m:g}m"


def _yz(est, th, kernel, bands, c, exp_auto, k_eff) -> MetricResult:
    tests, curves = [], []
    b = bands.bins
    f = est.freqs
    for s in est.separations:
        cc, pa, pb = est.yz[c][s]
        coh2 = np.abs(cc) ** 2 / (pa * pb)
        cocoh = cc.real / np.sqrt(pa * pb)
        rho = kernel.apply(th.yz[c][s]) / exp_auto
        n_eff = k_eff / th.rho(th.rho_yz[c][s], f)
        st = coherence_stats(rho, n_eff)
        lab = _sep_label(est, s)
        tests += bands.tests(f"coh2 {lab}", coh2, st["coh2_mean"], st["coh2_sd"], kind="chi2")
        tests += bands.tests(f"cocoh {lab}", cocoh, st["cocoh_mean"], st["cocoh_sd"])
        for name, e, m, sd in (("coh2", coh2, st["coh2_mean"], st["coh2_sd"]),
                               ("cocoh", cocoh, st["cocoh_mean"], st["cocoh_sd"])):
            lo, hi = _band95(e[b], sd[b])
            curves.append(Curve(f"{name} {lab}", f[b], e[b], m[b], lo, hi))
    return MetricResult(f"yz_coherence_{c}", f"yz coherence of {c} (magnitude-squared and co-coherence)", "-",
                        tests, curves)


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _longitudinal(est, th, kernel, bands, exp_auto_u, k_eff) -> MetricResult:
    tests, curves = [], []
    g = est.grid
    b = bands.bins
    f = est.freqs
    n_eff = k_eff / th.rho(th.rho_long, f)
    for p in range(g.nx):
        for q in range(p + 1, g.nx):
            cross = est.long_cross[p, q]
            coh2 = np.abs(cross) ** 2 / (est.long_auto[p] * est.long_auto[q])
            phase = np.angle(cross)
            rho = kernel.apply(th.long_lines(g.x_m[q] - g.x_m[p])) / exp_auto_u
            st = coherence_stats(rho, n_eff)
            lab = f"x={g.x_m[p]:g}m-{g.x_m[q]:g}m"
            tests += bands.tests(f"coh2 {lab}", coh2, st["coh2_mean"], st["coh2_sd"], kind="chi2")
            # expected phase 0 in the convected frame of the store
            tests += bands.tests(f"phase {lab}", phase, np.zeros_like(phase), st["phase_sd"], transform=_wrap)
            lo, hi = _band95(coh2[b], st["coh2_sd"][b])
            curves.append(Curve(f"coh2 {lab}", f[b], coh2[b], st["coh2_mean"][b], lo, hi))
            lo, hi = _band95(phase[b], st["phase_sd"][b])
            curves.append(Curve(f"phase {lab}", f[b], phase[b], np.zeros(b.size), lo, hi))
    return MetricResult("longitudinal_coherence_u",
                        "longitudinal coherence of u between planes (magnitude-squared and phase, convected frame)",
                        "-, rad", tests, curves)


def _uw(est, th, kernel, bands, exp_auto, k_eff) -> MetricResult:
    f = est.freqs
    b = bands.bins
    exp = kernel.apply(th.uw)
    norm_uw = np.sqrt(exp_auto["u"] * exp_auto["w"])
    rho = np.sqrt(th.rho(th.rho_all["u"], f) * th.rho(th.rho_all["w"], f)) + th.rho(th.rho_uw, f)
    sd = norm_uw * np.sqrt(rho / (2.0 * k_eff))
    co = est.uw.real
    # compared normalised by sqrt(S_u S_w) so every band weighs alike
    tests = bands.tests("co-spectrum/sqrt(SuSw)", co / norm_uw, exp / norm_uw, sd / norm_uw)
    lo, hi = _band95(co[b], sd[b])
    curve = Curve("uw_cross_spectrum", f[b], co[b], exp[b], lo, hi, th.reference.get("uw_cross_spectrum"))
    return MetricResult("uw_cross_spectrum", "u-w co-spectrum (Reynolds stress; 0 for Kaimal)", "m^2/s^2/Hz",
                        tests, [curve])

