"""Each tolerance law of the verdict against the spread of its estimate over many cheap realisations.

Issue 37 §6: single-line changes of the verdict that the suite let pass. Each was applied by hand to a scratch
copy of the code, this module run against it, and reverted (2026-11-28). The failing tests, with the largest
deviation of the first failing comparison in standard errors (se, below; the correct code stays within 3.5):

| mutation (one line) | fails |
|---|---|
| 1 mean check's sd from line 1, not line 0 (``verdict._mean``) | test_mean_sd_is_the_record_mean_line (-76 se), |
|   | test_a_mean_the_model_does_not_have_fails |
| 2 variance law without point averaging: rho_bar = 1 (``_variance``) | test_variance_sd_and_law_of_the_point_average |
|   (the same with only its sd, ``var = sum(lines**2)``) | (-18 se at sigma_u^2 already), the same |
| 3 adjacent plane pairs skipped, ``range(p + 2, nx)`` (``_longitudinal``) | test_every_plane_pair_is_judged, |
|   | test_longitudinal_coherence_of_independent_planes |
| 4 u-w co-spectrum sd without its cross term rho_uw (``_uw``) | test_uw_cospectrum_sd_and_law (9.4 se) |
| 5 co-coherence equivalent samples (1 - c*c) / (2 v) (``_uw``) | test_uw_cospectrum_sd_and_law (z^2: -34 se) |
| 6 one-point covariance, not the point-averaged one, for the | test_band_sd_of_the_averaged_spectra[u, v, w] |
|   spectra / longitudinal / yz coherences / REWS (``expectations``, | (-510 se), ..._of_independent_planes (-205), |
|   ``judge``), or for all (``Bands.averaged_cov``) | ..._of_independent_points (-490), ...[rews] (-16) |
| 7 neighbouring-bin correlation counted once, co-spectrum (``_uw``) | test_uw_cospectrum_sd_and_law (7.0 se) |
|   or band sums (``Bands.sum_var``) | test_one_point_spectrum_band_sd (7.3 se), and others |
| also: remaining modes without rho_bar (``variance_law.gamma_terms``) | test_variance_sd_and_law_... |
| also: lag 0 counted twice in the correlation sums (``pair_sums.weighted_gram``) | 7 tests |

Realisations are drawn from the validator's own null model, independently of the generators: the periodic
line process of ``prediction`` (circular Gaussian line amplitudes, E|Y_j|^2 = L_j, real at j = 0 and at the
Nyquist line; between points the model's coherency). Two designs:

* one point, a long record (2048 steps, Welch segments of 128) with chosen u, w lines (w ∝ u, u-w coherency
  -0.7 at every line, a record-mean line L_0 = L_1 / 4): the variances the verdict computes are exact there
  (Isserlis), so the empirical spread must match them to sampling error;
* a Kaimal model (U 10 m/s) on 3 planes (0, 20 m and 5 km: one coherent plane pair, two independent ones) of
  4 x 4 points, 512 steps: point averaging, the yz pairs, the plane pairs and the rotor series, estimated by the
  validator's own estimators (``span_sums``) from fields built with the model's coherency matrices.

Tolerances: an empirical variance s^2 of R realisations has the standard error sqrt((m4 - s^4 (R-3)/(R-1)) / R)
(m4 the fourth central moment, estimated from the same sample; sqrt(2/(R-1)) s^2 for Gaussian draws), an
empirical mean the error s / sqrt(R), a mean of z^2 the error sd(z^2) / sqrt(R). Every comparison allows
N_SE = 4.5 such errors: 6.8e-6 two-sided per comparison under a normal law; the mean of a skewed |C|^2 with few
equivalent samples has a heavier low tail of its t-statistic (Edgeworth: ~2e-5 at -4.5 for R = 150), so ~2e-3
for the ~165 comparisons of this module. The seeds are fixed, so the outcome is deterministic: the largest
deviation of the correct code is 3.5 se (yz coh2 of v at dz 10 m, second band), of each mutation above more than
N_SE (at least 7 se).
"""

import copy
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.signal

from turbgen.grid import Grid
from turbgen.spec.kaimal import KaimalRun, kaimal_params
from turbgen.store.layout import grid_to_attrs
from turbgen.theory.coherence_models import exponential_yz
from turbgen.theory.lattice import line_frequencies
from turbgen.validation import estimators, verdict
from turbgen.validation.band_checks import Bands
from turbgen.validation.estimators import Estimates, WelchSetup, plan_estimates, segment_starts
from turbgen.validation.span_sums import span_sums
from turbgen.validation.kaimal_expectation import kaimal_theory
from turbgen.validation.prediction import SamplingDesign, Theory
from turbgen.validation.welch_kernel import WelchKernel
from turbgen.validation.welch_variance import WelchCovariance

N_SE = 4.5  # allowed standard errors of an empirical moment (module docstring)


def _lines(rng, L, shape=()):
    """Circular Gaussian line amplitudes (*shape, nl) with E|Y_j|^2 = L_j, real at j = 0 and at the Nyquist line."""
    y = (rng.standard_normal((*shape, L.size)) + 1j * rng.standard_normal((*shape, L.size))) * np.sqrt(L / 2)
    y[..., [0, -1]] = np.sqrt(2) * y[..., [0, -1]].real
    return y


def _series(y, nt):
    """x_t = sum_q Y_q exp(i 2 pi q t / nt), Y_{nt-q} = conj(Y_q), along the last axis."""
    return np.fft.irfft(y, n=nt, axis=-1, norm="forward")


def _assert_variance(x, law_var, what):
    """Empirical variance of the rows of x (R, ...) within N_SE standard errors of ``law_var``."""
    x = np.asarray(x, float)
    r = x.shape[0]
    d = x - x.mean(0)
    s2 = np.sum(d**2, 0) / (r - 1)
    se = np.sqrt(np.maximum(np.mean(d**4, 0) - s2**2 * (r - 3) / (r - 1), 0.0) / r)
    dev = (s2 - law_var) / se
    assert np.all(np.abs(dev) < N_SE), f"{what}: empirical / law variance {s2 / law_var}, off by {dev} se"


def _assert_mean(x, law_mean, what):
    """Empirical mean of the rows of x (R, ...) within N_SE standard errors of ``law_mean``."""
    x = np.asarray(x, float)
    dev = (x.mean(0) - law_mean) / (x.std(0, ddof=1) / np.sqrt(x.shape[0]))
    assert np.all(np.abs(dev) < N_SE), f"{what}: empirical / law mean {x.mean(0) / law_mean}, off by {dev} se"


def _assert_unit_z2(z, what):
    """Mean of z^2 over realisations (R, ...) within N_SE standard errors of 1 (z a normal score)."""
    _assert_mean(np.asarray(z, float) ** 2, 1.0, f"{what} z^2")


# ---------------------------------------------------------------- one point, exact laws
NT_1, DT_1, NPERSEG_1 = 2048, 0.5, 128
C_UW = -0.7  # u-w coherency of every line
R_1 = 1200  # realisations: relative se of an empirical variance ~ sqrt(2 / R_1) = 4 %
R_1Z = 300  # of them judged one by one (the co-spectrum's exact law per band: ~15 ms a realisation)


def _one_point_theory():
    """Theory of one point: red u lines with a record-mean line L_0 = L_1 / 4, w = 0.3 u, u-w coherency C_UW."""
    f = line_frequencies(NT_1, DT_1)
    lu = (1.0 + (f * 40.0) ** 2) ** (-5 / 6) * f[1]
    lu[0] = 0.25 * lu[1]
    lw = 0.3 * lu
    nodes = np.geomspace(f[1], f[-1], 24)
    one = np.ones((nodes.size, nodes.size))  # R(nu_i, nu_j) of a single point
    none = {c: {} for c in "uvw"}
    return Theory(model="one point", nt=NT_1, line_f=f, auto={"u": lu, "v": lu, "w": lw}, yz=none, long={}, rews=lu,
                  node_f=nodes, rho_all={c: one for c in "uvw"}, rho_yz=none, rho_long=one, rho_rews=one,
                  sigma_model={}, band={}, uw=C_UW * np.sqrt(lu * lw), rho_uw=np.full(nodes.size, C_UW**2))


def _one_point_estimates():
    setup = WelchSetup(NPERSEG_1, DT_1)
    starts = tuple(segment_starts(NT_1, setup))
    return Estimates(setup, Grid(NT_1, DT_1, (0.0,), 1, 1, 1.0, 1.0), (), 1.0, np.ones((1, 1), bool),
                     np.zeros(1, int), np.zeros(1, int), n_segments=len(starts), n_overlapping_pairs=len(starts) - 1,
                     starts=starts, rews_segments=len(starts), rews_overlapping_pairs=len(starts) - 1)


def _one_point_expectations(est, th) -> SimpleNamespace:
    """What ``verdict.expectations`` holds for one point (its averages over points are the one-point covariance;
    their two-frequency sums are not computed, the costly part on this long record)."""
    kernel, bands = WelchKernel(est.setup, NT_1), Bands(est)
    wcov = WelchCovariance(est.setup, NT_1, est.starts)
    exp_auto = {c: kernel.apply(th.auto[c]) for c in "uvw"}
    cov = {c: bands.cov(wcov, th.auto[c], exp_auto[c]) for c in "uvw"}
    return SimpleNamespace(kernel=kernel, bands=bands, exp_auto=exp_auto, cov=cov)


@pytest.fixture(scope="module")
def one_point():
    """R_1 one-point records of u and w: record means, Welch u spectra and u-w cross-spectra (scipy's Welch)."""
    th, est = _one_point_theory(), _one_point_estimates()
    rng = np.random.default_rng(2026)
    yu = _lines(rng, th.auto["u"], (R_1,))
    yw = C_UW * np.sqrt(th.auto["w"] / th.auto["u"]) * yu + np.sqrt(1 - C_UW**2) * _lines(rng, th.auto["w"], (R_1,))
    xu, xw = _series(yu, NT_1), _series(yw, NT_1)
    welch = dict(fs=1 / DT_1, window="hann", nperseg=NPERSEG_1, noverlap=NPERSEG_1 // 2, detrend="constant")
    return {"th": th, "est": est, "ex": _one_point_expectations(est, th), "mean": xu.mean(axis=1),
            "pu": scipy.signal.welch(xu, **welch)[1], "puw": scipy.signal.csd(xu, xw, **welch)[1]}


def test_mean_sd_is_the_record_mean_line(one_point):
    # the record mean of one point is the line j = 0: variance L_0 (here L_1 / 4)
    est = copy.copy(one_point["est"])
    est.mean = {c: 0.0 for c in "uvw"}
    law = verdict._mean(est, one_point["th"]).checks[0].sigma
    _assert_variance(one_point["mean"][:, None], law**2, "record mean of u")


def test_one_point_spectrum_band_sd(one_point):
    # band means of the one-point Welch spectrum: exact covariance, neighbouring bins correlated
    ex, est = one_point["ex"], one_point["est"]
    checks = verdict._spectrum("spectrum_u", "", one_point["pu"][0], ex.exp_auto["u"], ex.cov["u"], ex.bands,
                               est.freqs).checks
    band_means = np.stack([one_point["pu"][:, g].mean(axis=1) for g in ex.bands.groups], axis=1)
    _assert_variance(band_means, np.array([c.sigma for c in checks]) ** 2, "one-point spectrum band mean")


def _uw_checks(one_point, r):
    est = copy.copy(one_point["est"])
    est.uw = one_point["puw"][r]
    ex = one_point["ex"]
    return verdict._uw(est, one_point["th"], ex.kernel, ex.bands, ex.exp_auto, ex.cov).checks


def test_uw_cospectrum_sd_and_law(one_point):
    # band co-coherence x = sum co / sqrt(sum E_u sum E_w): variance (1 + c^2) / (2 n) with neighbouring bins
    ex = one_point["ex"]
    checks = _uw_checks(one_point, 0)
    scale = np.array([np.sqrt(np.sum(ex.exp_auto["u"][g]) * np.sum(ex.exp_auto["w"][g])) for g in ex.bands.groups])
    x = np.stack([one_point["puw"][:, g].real.sum(axis=1) for g in ex.bands.groups], axis=1) / scale
    assert np.allclose(x[0], [c.estimate for c in checks])
    _assert_variance(x, np.array([c.sigma for c in checks]) ** 2, "u-w co-coherence")
    # and the law of x: its normal scores have unit variance (the equivalent samples n = (1 + c^2) / (2 Var))
    z = np.array([[c.z for c in _uw_checks(one_point, r)] for r in range(R_1Z)])
    _assert_unit_z2(z, "u-w co-coherence")


# ---------------------------------------------------------------- Kaimal, point and plane averages
U_K = 10.0
GRID_K = Grid(512, 0.5, (0.0, 20.0, 5000.0), 4, 4, 10.0, 10.0)  # planes 0-20 m coherent, 5 km away independent
R_K = 150  # realisations: relative se of an empirical variance ~ sqrt(2 / R_K) = 12 %


def _kaimal_factors(run: KaimalRun, f):
    """(nl, N, N) real lower-triangular A_j with A_j A_j^T the u coherency matrix of line j between all points
    (planes, y, z): the IEC exponential yz coherence (Guo et al. 2023, Eq. 12, un-squared) times the run's
    longitudinal one (Eq. 18)."""
    g = GRID_K
    x, y, z = (a.ravel() for a in np.meshgrid(np.asarray(g.x_m), g.y(), g.z(), indexing="ij"))
    r = np.hypot(y[:, None] - y[None, :], z[:, None] - z[None, :])
    dx = np.abs(x[:, None] - x[None, :])
    coh = exponential_yz(r[None], f[:, None, None], U_K, run.kaimal.a_yz, run.kaimal.lc_m)
    coh = coh * run.long_coherence()(dx[None], f[:, None, None])
    return np.linalg.cholesky(coh)  # unique (an eigen-factor is not, where eigenvalues are close)


def _kaimal_fields(rng, th: Theory, run: KaimalRun, n: int) -> list:
    """n fields of the line process of ``th``: u coherent as the model says, v, w white in y, z and independent
    between planes (the run's vw_coherence "white", long_components "u"); component -> (nx, nt, ny, nz)."""
    g = GRID_K
    shape = (n, g.nx * g.ny * g.nz)
    a = _kaimal_factors(run, th.line_f)
    white = _lines(rng, np.ones(th.line_f.size), shape).transpose(2, 1, 0)  # (nl, N, n)
    yu = np.matmul(a, white).transpose(2, 1, 0) * np.sqrt(th.auto["u"])
    y = {"u": yu, "v": _lines(rng, th.auto["v"], shape), "w": _lines(rng, th.auto["w"], shape)}
    x = {c: np.ascontiguousarray(_series(v, g.nt).reshape(n, g.nx, g.ny, g.nz, g.nt).transpose(0, 1, 4, 2, 3),
                                 np.float32) for c, v in y.items()}
    return [{c: x[c][k] for c in x} for k in range(n)]


def _estimate(plan, data):
    """The validator's estimates of one field: ``run_estimates`` without its dask graph (~0.1 s for a grid this
    small): each plane's sums (``span_sums``) over the whole record, combined by the estimators' own code."""
    est, g = copy.deepcopy(plan), GRID_K
    parts = [span_sums({c: data[c][ix] for c in data}, est.setup.window, segment_starts(g.nt, est.setup),
                       est.separations, est.rotor_mask, est.long_iy, est.long_iz) for ix in range(g.nx)]
    pairs = estimators._plane_pairs([p.pop("sub") for p in parts])
    estimators._combine(est, [(0, g.nt)], [(parts, pairs)])
    return est


@pytest.fixture(scope="module")
def kaimal():
    """R_K Kaimal fields estimated by the validator, the theory, and the verdict's checks of the first."""
    run = KaimalRun(kaimal=kaimal_params(U_K, "A", 90.0), grid=GRID_K, U_m_s=U_K, seed=1)
    assert run.vw_coherence == "white" and run.long_components == "u"
    plan = plan_estimates(SimpleNamespace(grid=GRID_K, chunk_t=GRID_K.nt), rotor_radius_m=15.0)  # one span
    th = kaimal_theory({**run.to_attrs(), "grid": grid_to_attrs(GRID_K)}, SamplingDesign.of(plan))
    fields = _kaimal_fields(np.random.default_rng(37), th, run, R_K)
    ests = [_estimate(plan, d) for d in fields]
    ex = verdict.expectations(ests[0], th)
    metrics = {m.name: m for m in verdict.judge(ests[0], th, expected=ex)}
    return {"th": th, "plan": plan, "ex": ex, "ests": ests, "fields": fields[:2], "metrics": metrics}


def _band_means(spectra, bands: Bands):
    """(R, bands) band means of (R, nf) spectra over the verdict's bands."""
    return np.stack([spectra[:, g].mean(axis=1) for g in bands.groups], axis=1)


def test_variance_sd_and_law_of_the_point_average(kaimal):
    # sigma^2 averaged over 48 points: Var = sum_j (w_j L_j)^2 rho_bar(f_j) (v, w white: rho_bar = 1/48 at
    # every line; u: the coherent lowest lines), and its gamma-sum law gives normal scores of unit variance
    for c in "uvw":
        law = kaimal["metrics"][f"sigma_{c}"].checks[0].sigma
        _assert_variance(np.array([[e.variance[c]] for e in kaimal["ests"]]), law**2, f"sigma_{c}^2")
        _assert_unit_z2([verdict._variance(e, kaimal["th"], c).checks[0].z for e in kaimal["ests"]], f"sigma_{c}^2")


@pytest.mark.parametrize("name", ["spectrum_u", "spectrum_v", "spectrum_w", "rews_spectrum"])
def test_band_sd_of_the_averaged_spectra(kaimal, name):
    # band means of the spectra averaged over all points and planes (REWS: over the planes' rotor series):
    # the exact covariance of the average (two-frequency correlation sums), neighbouring bins correlated
    bands = kaimal["ex"].bands
    spectra = np.array([e.rews_psd if name == "rews_spectrum" else e.auto[name[-1]] for e in kaimal["ests"]])
    law = np.array([c.sigma for c in kaimal["metrics"][name].checks])
    _assert_variance(_band_means(spectra, bands), law**2, name)


def _coh2(cross, auto_a, auto_b, bands: Bands):
    """(R, bands) band-pooled sample coherence |sum C|^2 / (sum A sum B) of (R, nf) sums."""
    return np.stack([np.abs(cross[:, g].sum(1)) ** 2 / (auto_a[:, g].sum(1) * auto_b[:, g].sum(1))
                     for g in bands.groups], axis=1)


def _coh2_expected(metric, label: str, n_bands: int) -> np.ndarray:
    """The verdict's expected |C|^2 of the pair ``label`` in each band (it must judge every band of the pair)."""
    expected = np.array([c.expected for c in metric.checks if c.label == f"coh2 {label}"])
    assert expected.size == n_bands, f"{metric.name}: {expected.size} coh2 checks of {label}, not {n_bands}"
    return expected


@pytest.mark.parametrize("c", ["v", "w"])
def test_yz_coherence_of_independent_points(kaimal, c):
    # v, w white in y, z: coherence 0 between the points of a pair, so the band-pooled |C|^2 has the mean
    # 1 / n_band of Goodman's law, n_band = (sum E)^2 / Var(sum of the auto-spectrum averaged over the pairs'
    # first points): the point average multiplies the equivalent samples by ~ the number of pairs
    bands, est0 = kaimal["ex"].bands, kaimal["ests"][0]
    metric = kaimal["metrics"][f"yz_coherence_{c}"]
    for s in est0.separations:
        cc, pa, pb = (np.array([e.yz[c][s][k] for e in kaimal["ests"]]) for k in range(3))
        label = verdict._sep_label(est0, s)
        _assert_mean(_coh2(cc, pa, pb, bands), _coh2_expected(metric, label, len(bands.groups)),
                     f"yz coh2 of {c} {label}")


def test_longitudinal_coherence_of_independent_planes(kaimal):
    # planes 5 km apart: |C|^2 of u between them has the mean gamma^2 + (1 - gamma^2)^2 / n_band (gamma^2 ~ 0),
    # n_band from the u spectrum averaged over the plane-pair sub-lattice (coherent points: not 16 x one point)
    bands, g = kaimal["ex"].bands, GRID_K
    metric = kaimal["metrics"]["longitudinal_coherence_u"]
    for p in (0, 1):
        cross = np.array([e.long_cross[p, 2] for e in kaimal["ests"]])
        auto_p, auto_q = (np.array([e.long_auto[k] for e in kaimal["ests"]]) for k in (p, 2))
        label = f"x={g.x_m[p]:g}m-{g.x_m[2]:g}m"
        _assert_mean(_coh2(cross, auto_p, auto_q, bands), _coh2_expected(metric, label, len(bands.groups)),
                     f"long coh2 {label}")


def _judge(kaimal, data) -> set:
    """Names of the metrics the verdict fails for the field ``data``."""
    est = _estimate(kaimal["plan"], data)
    return {m.name for m in verdict.judge(est, kaimal["th"], expected=kaimal["ex"]) if not m.passed}


def test_every_plane_pair_is_judged(kaimal):
    # planes 0 and 20 m from two different fields: only that adjacent pair breaks the model (the others are
    # independent in the model too), so the longitudinal coherence must fail; the field itself passes everything
    a, b = kaimal["fields"]
    assert _judge(kaimal, a) == set()
    mixed = {c: np.concatenate([a[c][:1], b[c][1:2], a[c][2:]]) for c in a}
    assert _judge(kaimal, mixed) == {"longitudinal_coherence_u"}


def test_a_mean_the_model_does_not_have_fails(kaimal):
    # the Kaimal record has no j = 0 line (L_0 = 0): a grand mean of 1e-3 sigma_u fails the mean, only it
    a = kaimal["fields"][0]
    assert kaimal["th"].auto["u"][0] == 0.0
    shifted = {**a, "u": a["u"] + np.float32(1e-3 * np.sqrt(kaimal["th"].variance("u")))}
    assert _judge(kaimal, shifted) == {"mean"}
