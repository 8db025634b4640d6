"""Pass/fail per metric, with tolerances derived from the statistical uncertainty of each estimator.

Null hypothesis: the field is a realisation of the store's model on the store's grid (``expectations``). Every
comparison becomes a normal score z from its exact or moment-matched law; a metric fails when any |z| exceeds
z_crit = Phi^-1(1 - ALPHA / (2 n)) (Bonferroni over its n comparisons), so a correct field fails a metric with
probability <= ALPHA (measured: benchmarks/calibration.md). Method and evidence: docs/validate.md.

Uncertainties (Gaussian fields):

* Welch covariance: exact (Isserlis) for the record's segment starts and, for an average over points/planes, for
  the set's two-frequency correlation sum R (``welch_variance``); the rule of thumb
  K_eff = K / (1 + 2 (1/36) K_adj / K) with Hann bin correlations 4/9, 1/36 only for very long records.
* Auto- and REWS spectra, per band (~5 bands per decade): chi2_nu / nu with nu = 2 E^2 / Var (Satterthwaite).
* Variance: Var = sum_j (w_j L_j)^2 rho_bar(f_j); its law a sum of gamma terms with the top modes of the lowest
  lines exact (``variance_law``).
* Coherences (yz, between planes), per band: the band-pooled sample coherency of n_band equivalent samples,
  n_band = (sum E_m)^2 / Var(sum of the averaged auto-spectrum), against Goodman's and the Rice phase law
  (``distributions``); near unit coherence the delta method with the float32 floor (``band_checks``).
* u-w co-spectrum: Var <= E_u E_w (sqrt(rho_u rho_w) + rho_uw) / (2 K_m) (Cauchy-Schwarz on the Isserlis
  covariance), against the exact variance-gamma law of the co-coherence.

Approximations: coherencies linear in log f between the rho nodes (at |f| for negative-frequency lines); rho_bar at
the bin centre in the u-w bound and the long-record fallback; the equivalent-samples description of averaged
coherences (conservative in the lowest bins); the gamma law of the spectra's band means; per-line gamma terms
beyond the top modes for the variances."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy.stats import chi2

from turbgen.validation.band_checks import Bands, coherence_stats
from turbgen.validation.checks import Check, Curve, MetricResult
from turbgen.validation.distributions import cospectrum_z, normal_score
from turbgen.validation.estimators import COMPONENTS, Estimates, segment_starts
from turbgen.validation.prediction import Theory
from turbgen.validation.variance_law import gamma_sum_tails, gamma_terms
from turbgen.validation.welch_kernel import WelchKernel
from turbgen.validation.welch_variance import WelchCovariance

FLOAT32_FLOOR = 1e-6  # relative resolution of float32 data (tolerance on a mean that is exactly 0)


def _band95(est, sd):
    return est - 1.96 * sd, est + 1.96 * sd


@dataclass
class Expectations:
    """The theory side of the verdict: expected Welch estimates and the covariances of the point-averaged estimates for
    the planned segments (needs the theory and the sampling design, not the data)."""

    kernel: WelchKernel
    bands: Bands
    exp_auto: dict  # component -> (nf,) expected auto-spectrum [m^2 s^-2 Hz^-1]
    cov: dict  # component -> {lag: covariance of the one-point estimate}
    cov_all: dict  # component -> covariance of the spectrum averaged over all points and planes
    cov_yz: dict  # component -> {separation: covariance averaged over the first points of its pairs}
    cov_long: dict  # covariance of the u spectrum averaged over the plane-pair sub-lattice of one plane
    exp_rews: np.ndarray  # (nf,) expected REWS spectrum
    rews_cov: dict  # covariance of the REWS spectrum (planes' series averaged)


def expectations(est: Estimates, th: Theory) -> Expectations:
    """The :class:`Expectations` of the planned estimates ``est`` (:func:`plan_estimates`) under the theory ``th``."""
    kernel = WelchKernel(est.setup, est.grid.nt)
    bands = Bands(est)
    f = est.freqs
    starts = est.starts or tuple(range(0, est.n_segments * est.setup.hop, est.setup.hop))
    wcov = WelchCovariance(est.setup, est.grid.nt, starts)
    exp_auto = {c: kernel.apply(th.auto[c]) for c in COMPONENTS}
    cov = {c: bands.cov(wcov, th.auto[c], exp_auto[c]) for c in COMPONENTS}  # one point
    terms = {c: wcov.node_terms(th.auto[c], th.node_f) for c in COMPONENTS}

    def averaged(c, rho2, w=wcov, t=None, one=None):  # covariance of the estimate averaged over a point set
        t = terms[c] if t is None else t
        return bands.averaged_cov(w, t, cov[c] if one is None else one, rho2, th.rho(rho2, f))

    cov_all = {c: averaged(c, th.rho_all[c]) for c in COMPONENTS}
    cov_yz = {c: {s: averaged(c, th.rho_yz[c][s]) for s in est.separations} for c in COMPONENTS}
    cov_long = averaged("u", th.rho_long)
    exp_r = kernel.apply(th.rews)
    rews_w = WelchCovariance(est.setup, est.grid.nt, segment_starts(est.grid.nt, est.setup))  # one span: whole record
    rews_one = bands.cov(rews_w, th.rews, exp_r)
    if not rews_w.feasible:  # rule of thumb: the REWS series has its own segment count
        rews_one = {d: v * bands.k_eff / est.rews_effective_segments for d, v in rews_one.items()}
    rews_cov = averaged("u", th.rho_rews, rews_w, rews_w.node_terms(th.rews, th.node_f), rews_one)
    return Expectations(kernel, bands, exp_auto, cov, cov_all, cov_yz, cov_long, exp_r, rews_cov)


def judge(est: Estimates, th: Theory, parallel: bool = False, expected: Expectations | None = None
          ) -> list[MetricResult]:
    """Pass/fail of every metric of the store (module docstring); ``parallel``: the longitudinal coherence in a
    second thread (the same results); ``expected``: ``expectations(est, th)`` if already computed."""
    ex = expected if expected is not None else expectations(est, th)
    kernel, bands, exp_auto = ex.kernel, ex.bands, ex.exp_auto
    f = est.freqs
    out = [_mean(est, th), *(_variance(est, th, c) for c in COMPONENTS)]
    second = ThreadPoolExecutor(max_workers=1, thread_name_prefix="turbgen-verdict") if parallel else nullcontext()
    with second as pool:
        task = partial(_longitudinal, est, th, kernel, bands, exp_auto["u"], ex.cov_long)
        longitudinal = pool.submit(task).result if pool else task  # alongside the others, or after them
        out += [_spectrum(f"spectrum_{c}", f"one-point spectrum of {c}", est.auto[c], exp_auto[c], ex.cov_all[c],
                          bands, f) for c in COMPONENTS]
        out += [_yz(est, th, kernel, bands, c, exp_auto[c], ex.cov_yz[c]) for c in COMPONENTS]
        uw = _uw(est, th, kernel, bands, exp_auto, ex.cov)
        rews = _spectrum("rews_spectrum", f"rotor-effective wind speed spectrum (R = {est.rotor_radius_m:g} m)",
                         est.rews_psd, ex.exp_rews, ex.rews_cov, bands, f)
        out += [longitudinal(), uw, rews]
    return out


def _mean(est: Estimates, th: Theory) -> MetricResult:
    # The grand mean is the average of the j = 0 lines Z_0 (variance L_0 per point); averaging over
    # points can only lower the variance, so sd = sqrt(L_0) is conservative.
    sd = {c: np.sqrt(th.auto[c][0] + (FLOAT32_FLOOR**2) * th.variance(c)) for c in COMPONENTS}
    checks = [Check(c, None, est.mean[c], 0.0, float(sd[c]), float(est.mean[c] / sd[c])) for c in COMPONENTS]
    return MetricResult("mean", "mean of u, v, w", "m/s", checks)


def _variance(est: Estimates, th: Theory, c: str) -> MetricResult:
    # line pair j: 2|Z_j|^2 is exponential with variance (2 L_j)^2, times rho_bar(f_j) for the point average
    lines = th.auto[c][1:] * th.pair_weights[1:]
    rho = th.rho(th.rho_all[c], th.line_f[1:])
    sd = float(np.sqrt(np.sum(lines**2 * rho)))
    z = float(normal_score(*gamma_sum_tails(est.variance[c], *gamma_terms(lines, rho, th.variance_modes.get(c)))))
    return MetricResult(f"sigma_{c}", f"variance of {c} (sigma_{c}, TI)", "m^2/s^2",
                        [Check(f"sigma_{c}^2", None, est.variance[c], th.variance(c), sd, z)])


def _spectrum(name, title, estimate, expected, cov, bands: Bands, f) -> MetricResult:
    # band mean ratio estimate/expected ~ chi2_nu/nu with nu = 2 E^2 / Var (exact covariance of the point average)
    checks = bands.spectrum_checks(name.split("_")[-1], estimate, expected, cov)
    b = bands.bins
    nu = 2.0 * expected[b] ** 2 / cov[0][b]  # 95 % interval of a chi2_nu/nu estimate (always positive)
    lo, hi = estimate[b] * nu / chi2.ppf(0.975, nu), estimate[b] * nu / chi2.ppf(0.025, nu)
    curve = Curve(name, f[b], estimate[b], expected[b], lo, hi)
    return MetricResult(name, title, "m^2/s^2/Hz", checks, [curve])


def _sep_label(est: Estimates, s) -> str:
    return f"dy={s[0] * est.grid.dy_m:g}m dz={s[1] * est.grid.dz_m:g}m"


def _pair(est, bands, lab, cross, auto_a, auto_b, rho, exp_auto, cov, n, phase_expected) -> tuple[list, list]:
    """Band checks (``Bands.coherence_checks``) and per-bin coh2 and phase curves of one pair of averaged spectra;
    ``n``: equivalent samples per bin of the per-bin bands for the plots."""
    b, f = bands.bins, est.freqs
    st = coherence_stats(rho, n)
    curves = []
    for name, e, m, sd in (("coh2", np.abs(cross) ** 2 / (auto_a * auto_b), st["coh2_mean"], st["coh2_sd"]),
                           ("phase", np.angle(cross), phase_expected, st["phase_sd"])):
        lo, hi = _band95(e[b], sd[b])
        curves.append(Curve(f"{name} {lab}", f[b], e[b], m[b], lo, hi))
    return bands.coherence_checks(lab, cross, auto_a, auto_b, rho, exp_auto, cov), curves


def _yz(est, th, kernel, bands, c, exp_auto, covs) -> MetricResult:
    # covs: separation -> covariance of the auto-spectrum averaged over the first points of its pairs
    checks, curves = [], []
    for s in est.separations:
        cc, pa, pb = est.yz[c][s]
        rho = kernel.apply(th.yz[c][s]) / exp_auto
        more, pair_curves = _pair(est, bands, _sep_label(est, s), cc, pa, pb, rho, exp_auto, covs[s],
                                  exp_auto**2 / covs[s][0], np.angle(rho))
        checks += more
        curves += pair_curves
    return MetricResult(f"yz_coherence_{c}", f"yz coherence of {c} (magnitude-squared and phase)", "-, rad",
                        checks, curves)


def _longitudinal(est, th, kernel, bands, exp_auto_u, cov_u) -> MetricResult:
    # cov_u: covariance of the u auto-spectrum averaged over the plane-pair sub-lattice of one plane
    checks, curves = [], []
    g = est.grid
    n_bins = exp_auto_u**2 / cov_u[0]
    for p in range(g.nx):
        for q in range(p + 1, g.nx):
            rho = kernel.apply(th.long_lines(g.x_m[q] - g.x_m[p])) / exp_auto_u
            # expected phase arg(rho) = 0 in the convected frame of the store
            more, pair_curves = _pair(est, bands, f"x={g.x_m[p]:g}m-{g.x_m[q]:g}m", est.long_cross[p, q],
                                      est.long_auto[p], est.long_auto[q], rho, exp_auto_u, cov_u, n_bins,
                                      np.zeros(n_bins.size))
            checks += more
            curves += pair_curves
    return MetricResult("longitudinal_coherence_u",
                        "longitudinal coherence of u between planes (magnitude-squared and phase, convected frame)",
                        "-, rad", checks, curves)


def _uw(est, th, kernel, bands, exp_auto, cov) -> MetricResult:
    # the bound of the module docstring per bin, K_m = sqrt(K_u K_w) (K_x = E_x^2 / Var_x of one point), neighbouring
    # bins correlated as sqrt(corr_u corr_w); per band the pooled co-coherence against its variance-gamma law
    f = est.freqs
    b = bands.bins
    exp = kernel.apply(th.uw)
    eu, ew = exp_auto["u"], exp_auto["w"]
    norm_uw = np.sqrt(eu * ew)
    rho = np.sqrt(th.rho(th.rho_all["u"], f) * th.rho(th.rho_all["w"], f)) + th.rho(th.rho_uw, f)

    def lag_corr(c, d):  # correlation of bins d apart of the one-point estimate with covariance dict c
        return np.clip(c[d] / np.sqrt(c[0][: f.size - d] * c[0][d:]), 0, 1)

    with np.errstate(divide="ignore", invalid="ignore"):
        k_m = np.sqrt(eu**2 / cov["u"][0] * ew**2 / cov["w"][0])
        sd = np.nan_to_num(norm_uw * np.sqrt(rho / (2.0 * k_m)))
        sd_cov = {d: sd[: f.size - d] * sd[d:] * np.nan_to_num(np.sqrt(lag_corr(cov["u"], d) * lag_corr(cov["w"], d)))
                  for d in cov["u"]}
    co = est.uw.real
    checks = []
    for g in bands.groups:
        scale = np.sqrt(np.sum(eu[g]) * np.sum(ew[g]))
        x, c = float(np.sum(co[g]) / scale), float(np.sum(exp[g]) / scale)
        v = bands.sum_var(sd_cov, g) / scale**2
        n_band = (1.0 + c * c) / (2.0 * v)
        z = float(cospectrum_z(x, c, n_band))
        checks.append(Check("co-spectrum/sqrt(SuSw)", (float(f[g[0]]), float(f[g[-1]])), x, c, float(np.sqrt(v)), z))
    lo, hi = _band95(co[b], sd[b])
    curve = Curve("uw_cross_spectrum", f[b], co[b], exp[b], lo, hi)
    return MetricResult("uw_cross_spectrum", "u-w co-spectrum (Reynolds stress; 0 for Kaimal)", "m^2/s^2/Hz",
                        checks, [curve])
