"""Pass/fail per metric, with tolerances derived from the statistical uncertainty of each estimator.

Null hypothesis: the field is a realisation of the store's model on the store's grid
(``expectations``). Every comparison is turned into a normal score z (from its exact or
moment-matched law, so |z| > z means the same tail probability for every test); a metric fails
when any of its |z| exceeds z_crit = Phi^-1(1 - ALPHA / (2 n)), n the number of comparisons in the
metric (Bonferroni: valid whatever the correlation between the comparisons), so a correct field
fails a given metric with probability <= ALPHA. No fixed fudge factor enters. The false-failure
rate as measured over ~500 correct fields (nt 256 .. 4096, 2 .. 11 planes, both models) is in
benchmarks/calibration.md (``benchmarks/calibrate_validate.py``).

Uncertainties (Gaussian fields; derivations in the comments below):
* Welch covariance (``welch_variance``): the one-point Welch estimate of the model's line process is
  a quadratic form in the line amplitudes, so its covariance between bins m, m' is exact (Isserlis)
  for the record's actual segment starts: overlap for a coloured spectrum, correlation of
  non-overlapping segments where the spectrum varies within a bin (the lowest bins of short records:
  nt = 512 has ~12 instead of the rule-of-thumb 14.3 equivalent segments at bin 1), per-segment mean
  removal, coloured neighbouring bins. (Very long records fall back to the rule of thumb
  K_eff = K / (1 + 2 (1/36) K_adj / K), Hann bin correlations 4/9, 1/36, accurate there.)
* Averaging over points/planes does not multiply the number of independent samples by the
  number of points: Cov(P_p, P_q) = E P_p E P_q coh2_pq (Isserlis), so the average over a point
  set has the one-point covariance times rho_bar, the mean of the model's coh2 over all ordered
  pairs of the set (``Theory.rho_*``; 1 for fully coherent points, 1/N for independent ones).
  The same holds for averages of cross-products conj(X_p) X_{p+d} over p.
* Auto-spectra and REWS spectra, per band (bins grouped ~5 per decade): the band mean has the exact
  mean and variance above; compared as chi2_nu / nu with nu = 2 E^2 / Var (Satterthwaite).
* Variance: one-sided line pair j contributes 2|Z_j|^2 (exponential, variance (2 L_j)^2), so
  Var(sigma^2 estimate) = sum_j (w_j L_j)^2 rho_bar(f_j); compared as chi2 with nu = 2 E^2/Var.
* Coherences (yz and between planes), per band: the band-pooled sample coherency
  C = sum cross / sqrt(sum A sum B) is the sample coherency of n_band equivalent independent samples,
  n_band = (sum E_m)^2 / Var(sum of the point-averaged auto-spectrum over the band); |C|^2 is compared
  with Goodman's exact law of the sample magnitude-squared coherence and arg C with the exact
  (Rice) phase law (``distributions``), not with delta-method normal laws: at low coherence
  (n gamma2 of order 10) |C|^2 is a noncentral chi2 with 2 degrees of freedom whose lower tail is far
  heavier than any Gaussian or gamma law with the same moments (a 1e-4 event looked like z = -5.6),
  and the phase is heavy-tailed as well. Near unit coherence (frozen planes) the delta method with
  the float32 resolution floor is used (``coherence_stats``: Var coh2 = 2 g (1-g)^2/n + bias^2,
  Var phase = (1-g)/(2 n g)).
* u-w co-spectrum: Var of the point average <= E_u E_w (sqrt(rho_u rho_w) + rho_uw) / (2 K_m)
  (Cauchy-Schwarz on the Isserlis covariance; rho_uw the mean |u-w coherency|^2 over pairs; K_m the
  exact equivalent segments of bin m); the band-pooled co-coherence is compared with the exact
  variance-gamma law of that many equivalent samples (exponential, not Gaussian, tails).

Approximations, stated: the rho_bar are evaluated at the bin centre (interpolated from nodes);
the equivalent-samples description of point-averaged coherences (exact for independent points or
one point); the gamma law for the spectra's band means.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2, norm

from turbgen.validate.distributions import coh2_z, cospectrum_z, phase_z
from turbgen.validate.estimators import COMPONENTS, Estimates, segment_starts
from turbgen.validate.prediction import Theory
from turbgen.validate.welch_kernel import WelchKernel
from turbgen.validate.welch_variance import MAX_LAG, WelchCovariance

ALPHA = 1e-3  # family-wise probability that a correct field fails one given metric
BANDS_PER_DECADE = 5
FLOAT32_FLOOR = 1e-6  # relative resolution of float32 data (tolerance on a mean that is exactly 0)
COHERENCE_FLOOR = 1e-5  # absolute resolution of a coherence estimated from float32 data
NEAR_UNIT = 1e-3  # 1 - |rho|^2 below this: delta method with the float32 floor (frozen planes), not the exact laws


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
    """Welch bins 1 .. n/2-1 grouped into log-spaced bands; band statistics from the Welch covariance.

    ``cov``: one-point covariance of the Welch estimate, lag d -> Cov(P_m, P_{m+d}) (``welch_variance``,
    exact for the record's segments), or the rule-of-thumb model E_m E_m' r_d / K_eff (r_d the Hann
    bin correlations 1, 4/9, 1/36) when the exact sums are too long (very long records).
    """

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
        self.k_eff = est.effective_segments

    def cov(self, wcov: WelchCovariance, lines: np.ndarray, expected: np.ndarray) -> dict:
        """One-point covariance dict of the Welch estimate of ``lines`` (expected estimate ``expected``)."""
        exact = wcov.cov(lines)
        if exact is not None:
            return exact
        e = np.asarray(expected, float)
        return {d: e[: e.size - d] * e[d:] * self.lag_corr.get(d, 0.0) / self.k_eff for d in range(MAX_LAG + 1)}

    @staticmethod
    def sum_var(cov: dict, rho: np.ndarray, group: np.ndarray) -> float:
        """Variance of the sum over the bins ``group`` of the point-averaged estimate (rho: rho_bar per bin)."""
        total = 0.0
        r = np.sqrt(np.asarray(rho, float))
        for d, c in cov.items():
            a = group[group + d <= group[-1]]
            part = np.sum(c[a] * r[a] * r[a + d])
            total += part if d == 0 else 2.0 * part
        return float(total)

    def spectrum_tests(self, label, est, exp, cov, rho) -> list[Test]:
        """Band means of a point-averaged Welch spectrum: ratio ~ chi2_nu / nu, nu = 2 E^2 / Var (gamma law
        with the exact mean and variance; Welch 1967 / Satterthwaite equivalent degrees of freedom)."""
        out = []
        for g in self.groups:
            e, x = float(np.mean(est[g])), float(np.mean(exp[g]))
            s = np.sqrt(self.sum_var(cov, rho, g)) / g.size
            z = float(_chi2_z(e / x, 2.0 * (x / s) ** 2)) if x > 0 and s > 0 else 0.0
            out.append(Test(label, (float(self.f[g[0]]), float(self.f[g[-1]])), e, x, float(s), z))
        return out

    def coherence_tests(self, label, cross, auto_a, auto_b, rho_lines, exp_auto, cov, rho_bar) -> list[Test]:
        """Exact-law tests of the band-pooled sample coherency C = sum_g cross / sqrt(sum_g A sum_g B).

        Its expectation is rho_band = sum_g rho_m E_m / sum_g E_m (E_m the expected auto-spectrum of both
        point sets), and it is treated as the sample coherency of n_band independent samples with
        n_band = (sum_g E_m)^2 / Var(sum_g A) (the equivalent number of independent periodograms of the
        pooled, point-averaged auto-spectrum, exact Welch covariance). |C|^2 then follows Goodman's law and
        arg C - arg rho_band the Rice phase law (``distributions``). Near unit coherence (1 - |rho|^2 <
        NEAR_UNIT) the delta method with the float32 floor is used instead (``coherence_stats``).
        """
        gs = self.groups
        c = np.array([np.sum(cross[g]) for g in gs])
        a = np.array([np.sum(auto_a[g]) for g in gs])
        b = np.array([np.sum(auto_b[g]) for g in gs])
        e_sum = np.array([np.sum(exp_auto[g]) for g in gs])
        rho_band = np.array([np.sum(rho_lines[g] * exp_auto[g]) for g in gs]) / e_sum
        n_band = e_sum**2 / np.array([self.sum_var(cov, rho_bar, g) for g in gs])
        coh = c / np.sqrt(a * b)
        gam2 = np.minimum(np.abs(rho_band) ** 2, 1.0)
        dphi = _wrap(np.angle(coh) - np.angle(rho_band))
        st = coherence_stats(rho_band, n_band)
        near = 1.0 - gam2 < NEAR_UNIT
        g_exact = np.where(near, 0.5, gam2)  # (placeholder where the delta method is used)
        z_coh = np.where(near, (np.abs(coh) ** 2 - st["coh2_mean"]) / st["coh2_sd"], coh2_z(np.abs(coh) ** 2, g_exact,
                                                                                              n_band))
        z_ph = np.where(near, dphi / st["phase_sd"], phase_z(dphi, g_exact, n_band))
        out = []
        for i, g in enumerate(gs):
            band = (float(self.f[g[0]]), float(self.f[g[-1]]))
            out.append(Test(f"coh2 {label}", band, float(abs(coh[i]) ** 2), float(st["coh2_mean"][i]),
                            float(st["coh2_sd"][i]), float(z_coh[i])))
            out.append(Test(f"phase {label}", band, float(np.angle(coh[i])), float(np.angle(rho_band[i])),
                            float(st["phase_sd"][i]), float(z_ph[i])))
        return out


def _band95(est, sd):
    return est - 1.96 * sd, est + 1.96 * sd


def judge(est: Estimates, th: Theory) -> list[MetricResult]:
    """All metrics of the store."""
    kernel = WelchKernel(est.setup, est.grid.nt)
    bands = _Bands(est)
    f = est.freqs
    starts = est.starts or tuple(range(0, est.n_segments * est.setup.hop, est.setup.hop))
    wcov = WelchCovariance(est.setup, est.grid.nt, starts)
    out = [_mean(est, th), *(_variance(est, th, c) for c in COMPONENTS)]
    exp_auto = {c: kernel.apply(th.auto[c]) for c in COMPONENTS}
    cov = {c: bands.cov(wcov, th.auto[c], exp_auto[c]) for c in COMPONENTS}
    for c in COMPONENTS:
        out.append(_spectrum(f"spectrum_{c}", f"one-point spectrum of {c}", est.auto[c], exp_auto[c], cov[c],
                             th.rho(th.rho_all[c], f), bands, f, th.reference.get(f"spectrum_{c}")))
    for c in COMPONENTS:
        out.append(_yz(est, th, kernel, bands, c, exp_auto[c], cov[c]))
    out.append(_longitudinal(est, th, kernel, bands, exp_auto["u"], cov["u"]))
    out.append(_uw(est, th, kernel, bands, exp_auto, cov))
    exp_r = kernel.apply(th.rews)
    rews_w = WelchCovariance(est.setup, est.grid.nt, segment_starts(est.grid.nt, est.setup))  # one span: whole record
    rews_cov = bands.cov(rews_w, th.rews, exp_r)
    if not rews_w.feasible:  # rule of thumb: the REWS series has its own segment count
        rews_cov = {d: v * bands.k_eff / est.rews_effective_segments for d, v in rews_cov.items()}
    out.append(_spectrum("rews_spectrum", f"rotor-effective wind speed spectrum (R = {est.rotor_radius_m:g} m)",
                         est.rews_psd, exp_r, rews_cov, th.rho(th.rho_rews, f), bands, f,
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


def _spectrum(name, title, estimate, expected, cov, rho, bands: _Bands, f, reference) -> MetricResult:
    # band mean ratio estimate/expected ~ chi2_nu/nu with nu = 2 E^2 / Var (exact Welch covariance x rho_bar)
    tests = bands.spectrum_tests(name.split("_")[-1], estimate, expected, cov, rho)
    b = bands.bins
    nu = 2.0 * expected[b] ** 2 / (cov[0][b] * rho[b])  # 95 % interval of a chi2_nu/nu estimate (always positive)
    lo, hi = estimate[b] * nu / chi2.ppf(0.975, nu), estimate[b] * nu / chi2.ppf(0.025, nu)
    curve = Curve(name, f[b], estimate[b], expected[b], lo, hi, reference)
    return MetricResult(name, title, "m^2/s^2/Hz", tests, [curve])


def _sep_label(est: Estimates, s) -> str:
    return f"dy={s[0] * est.grid.dy_m:g}m dz={s[1] * est.grid.dz_m:g}m"


def _yz(est, th, kernel, bands, c, exp_auto, cov) -> MetricResult:
    tests, curves = [], []
    b = bands.bins
    f = est.freqs
    for s in est.separations:
        cc, pa, pb = est.yz[c][s]
        coh2 = np.abs(cc) ** 2 / (pa * pb)
        phase = np.angle(cc)
        rho = kernel.apply(th.yz[c][s]) / exp_auto
        rho_bar = th.rho(th.rho_yz[c][s], f)
        lab = _sep_label(est, s)
        tests += bands.coherence_tests(lab, cc, pa, pb, rho, exp_auto, cov, rho_bar)
        st = coherence_stats(rho, exp_auto**2 / (cov[0] * rho_bar))  # per-bin bands for the plots
        for name, e, m, sd in (("coh2", coh2, st["coh2_mean"], st["coh2_sd"]),
                               ("phase", phase, np.angle(rho), st["phase_sd"])):
            lo, hi = _band95(e[b], sd[b])
            curves.append(Curve(f"{name} {lab}", f[b], e[b], m[b], lo, hi))
    return MetricResult(f"yz_coherence_{c}", f"yz coherence of {c} (magnitude-squared and phase)", "-, rad",
                        tests, curves)


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _longitudinal(est, th, kernel, bands, exp_auto_u, cov_u) -> MetricResult:
    tests, curves = [], []
    g = est.grid
    b = bands.bins
    f = est.freqs
    rho_bar = th.rho(th.rho_long, f)
    n_bins = exp_auto_u**2 / (cov_u[0] * rho_bar)
    for p in range(g.nx):
        for q in range(p + 1, g.nx):
            cross = est.long_cross[p, q]
            coh2 = np.abs(cross) ** 2 / (est.long_auto[p] * est.long_auto[q])
            phase = np.angle(cross)
            rho = kernel.apply(th.long_lines(g.x_m[q] - g.x_m[p])) / exp_auto_u
            lab = f"x={g.x_m[p]:g}m-{g.x_m[q]:g}m"
            # expected phase arg(rho) = 0 in the convected frame of the store
            tests += bands.coherence_tests(lab, cross, est.long_auto[p], est.long_auto[q], rho, exp_auto_u, cov_u,
                                           rho_bar)
            st = coherence_stats(rho, n_bins)
            lo, hi = _band95(coh2[b], st["coh2_sd"][b])
            curves.append(Curve(f"coh2 {lab}", f[b], coh2[b], st["coh2_mean"][b], lo, hi))
            lo, hi = _band95(phase[b], st["phase_sd"][b])
            curves.append(Curve(f"phase {lab}", f[b], phase[b], np.zeros(b.size), lo, hi))
    return MetricResult("longitudinal_coherence_u",
                        "longitudinal coherence of u between planes (magnitude-squared and phase, convected frame)",
                        "-, rad", tests, curves)


def _uw(est, th, kernel, bands, exp_auto, cov) -> MetricResult:
    # Per bin: Var(co) <= E_u E_w (sqrt(rho_u rho_w) + rho_uw) / (2 K_m) (Cauchy-Schwarz on the Isserlis
    # covariance, exact for one point), K_m = sqrt(K_u K_w) the exact equivalent segments of the u and w
    # Welch estimates (K_x = E_x^2 / Var_x one point); neighbouring bins correlated as sqrt(corr_u corr_w).
    # Per band the pooled co-coherence sum co / sqrt(sum E_u sum E_w) is compared with the exact
    # variance-gamma law of n_band equivalent samples (``distributions.cospectrum_tails``).
    f = est.freqs
    b = bands.bins
    exp = kernel.apply(th.uw)
    eu, ew = exp_auto["u"], exp_auto["w"]
    norm_uw = np.sqrt(eu * ew)
    rho = np.sqrt(th.rho(th.rho_all["u"], f) * th.rho(th.rho_all["w"], f)) + th.rho(th.rho_uw, f)
    with np.errstate(divide="ignore", invalid="ignore"):
        k_m = np.sqrt(eu**2 / cov["u"][0] * ew**2 / cov["w"][0])
        sd = np.nan_to_num(norm_uw * np.sqrt(rho / (2.0 * k_m)))
        corr = {d: np.nan_to_num(np.sqrt(np.clip(cov["u"][d] / np.sqrt(cov["u"][0][: f.size - d] * cov["u"][0][d:]), 0, 1)
                                         * np.clip(cov["w"][d] / np.sqrt(cov["w"][0][: f.size - d] * cov["w"][0][d:]),
                                                   0, 1)))
                for d in cov["u"]}
    co = est.uw.real
    tests = []
    for g in bands.groups:
        var = 0.0
        for d, r in corr.items():
            m = g[g + d <= g[-1]]
            part = np.sum(sd[m] * sd[m + d] * r[m])
            var += part if d == 0 else 2.0 * part
        scale = np.sqrt(np.sum(eu[g]) * np.sum(ew[g]))
        x, c = float(np.sum(co[g]) / scale), float(np.sum(exp[g]) / scale)
        v = var / scale**2
        n_band = (1.0 + c * c) / (2.0 * v)
        z = float(cospectrum_z(x, c, n_band))
        tests.append(Test("co-spectrum/sqrt(SuSw)", (float(f[g[0]]), float(f[g[-1]])), x, c, float(np.sqrt(v)), z))
    lo, hi = _band95(co[b], sd[b])
    curve = Curve("uw_cross_spectrum", f[b], co[b], exp[b], lo, hi, th.reference.get("uw_cross_spectrum"))
    return MetricResult("uw_cross_spectrum", "u-w co-spectrum (Reynolds stress; 0 for Kaimal)", "m^2/s^2/Hz",
                        tests, [curve])
