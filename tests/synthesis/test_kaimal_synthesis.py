"""Statistics of the Kaimal 4D synthesis (turbgen.synthesis.kaimal_evo) on small grids, fixed seeds.

Estimator variances used for the tolerances (derivations, all for circular complex Gaussian
Fourier coefficients X_k, independent between frequency bins k):

* Spectra: with X = rfft(x, norm="forward"), E[2 |X_k|^2] = v_k (the band integral of Eq. 11 over
  bin k). For the mean over N points (planes x yz points) of 2|X_k|^2 / v_k the variance is
  sum_ab rho_ab^2 / N^2 with rho_ab the correlation of the coefficients at a, b (|X|^2 of a
  circular Gaussian has variance mean^2, covariances |rho|^2 mean^2). rho is the direct product
  coh_yz * gamma_x, so sum_ab rho^2 = (sum_pq gamma_x^2)(sum_ab coh_yz^2). Averaging K bins
  divides by K^2 the sum of the per-bin variances.
* Coherence: c = sum X_a X_b^* / sqrt(sum |X_a|^2 sum |X_b|^2) over n independent samples with
  true real coherence g: Var(Re c) ~= (1 - g^2)^2 / (2 n), Var(Im c) ~= (1 - g^2) / (2 n) (Goodman;
  write X_b = g X_a + sqrt(1 - g^2) E), bias O((1 - g^2) / n). Samples of unequal variance v_k
  count as n_eff = (sum v_k)^2 / sum v_k^2 per independent series, and the target is the
  v-weighted mean of g over the band.
* Variance: the sample variance over all points and times is sum_k (mean_a 2|X_ak|^2), with
  variance sum_k v_k^2 sum_ab rho_ab(k)^2 / N^2 (x2 for the real Nyquist bin).
Every check uses Z = 4.5 standard deviations (two-sided p ~ 7e-6 per check, < 1e-3 for the file).
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from turbgen.grid import Grid
from turbgen.synthesis.circulant import grid_distances
from turbgen.synthesis.kaimal_evo import (
    FREQ_CHUNK,
    KaimalEvo,
    PlaneRing,
    bin_frequencies,
    bin_variances,
    inverse_transform,
)
from turbgen.theory.coherence_models import exponential_longitudinal, exponential_yz, kristensen, simley_pao
from turbgen.theory.kaimal import iec_kaimal_params, kaimal_band_variance
from turbgen.theory.params import KaimalParams

Z = 4.5
U = 16.0
KP = iec_kaimal_params(U, "A", 90.0)
EXP = partial(exponential_longitudinal, U_m_s=U, a_x=1.8, b_x=1.49e-4)


def _independent_planes(dx_m, f_hz):
    return np.where(np.asarray(dx_m) == 0, 1.0, 0.0) + 0.0 * np.asarray(f_hz)


def _field(gen, c):
    """(nx, nt, ny, nz) float32 of one component."""
    return np.stack([p for _, p in gen.component_planes(c)])


def _coefs(x):
    return np.fft.rfft(x.astype(np.float64), axis=1, norm="forward")


# -- one-point spectra ------------------------------------------------------------------------------
def test_one_point_spectra_follow_kaimal():
    g = Grid(4096, 0.5, (0.0, 40.0, 100.0), 6, 6, 10.0, 10.0)
    gen = KaimalEvo(KP, g, U, 3, long_coherence=EXP)
    f = bin_frequencies(g.nt, g.dt_s)
    yz = grid_distances(g.ny, g.nz, g.dy_m, g.dz_m)
    dx = np.abs(np.subtract.outer(g.x(), g.x()))
    n_pts = g.nx * g.ny * g.nz
    edges = [4, 16, 64, 256, 1024, 2048]  # bins; Nyquist (2048) excluded
    for i, c in enumerate("uvw"):
        v = bin_variances(g.nt, g.dt_s, KP.sigma_m_s[i], KP.length_scales_m[i], U)
        # the bins follow the PSD of Eq. 11: v_k / df is S(k df) to within the curvature over one bin
        s = 4 * KP.sigma_m_s[i] ** 2 * (KP.length_scales_m[i] / U) / (1 + 6 * f * KP.length_scales_m[i] / U) ** (5 / 3)
        np.testing.assert_allclose(v[1:-1] / (f[1]), s[1:-1], rtol=2e-3)
        p = (2 * np.abs(_coefs(_field(gen, c))) ** 2).mean(axis=(0, 2, 3))
        for lo, hi in zip(edges[:-1], edges[1:]):
            k = np.arange(lo, hi)
            if c == "u":
                s2 = np.array([(EXP(dx, f[j]) ** 2).sum() * (exponential_yz(yz, f[j], U) ** 2).sum() for j in k])
            else:
                s2 = np.full(k.size, float(n_pts))
            sd = np.sqrt((s2 / n_pts**2).sum()) / k.size
            ratio = (p[k] / v[k]).mean()
            assert abs(ratio - 1) < Z * sd, (c, lo, hi, ratio, sd)


# -- yz coherence of u ------------------------------------------------------------------------------
def _coherence_check(xa, xb, v, k, target, what):
    """Re/Im of the averaged coherence over bins k (and the leading axis) against a real target."""
    num = (xa[:, k] * xb[:, k].conj()).sum()
    c = num / np.sqrt((np.abs(xa[:, k]) ** 2).sum() * (np.abs(xb[:, k]) ** 2).sum())
    n = xa.shape[0] * v[k].sum() ** 2 / (v[k] ** 2).sum()
    sd_re = (1 - target**2) / np.sqrt(2 * n)
    sd_im = np.sqrt((1 - target**2) / (2 * n))
    assert abs(c.real - target) < Z * sd_re + (1 - target**2) / n, (what, c, target, sd_re)
    assert abs(c.imag) < Z * sd_im, (what, c, sd_im)


def test_yz_coherence_of_u_is_eq12_unsquared():
    x = tuple(float(i) * 1000 for i in range(8))  # planes made independent: 8 independent samples per bin
    g = Grid(4096, 0.5, x, 5, 3, 5.0, 5.0)
    gen = KaimalEvo(KP, g, U, 5, long_coherence=_independent_planes)
    xu = _coefs(_field(gen, "u"))
    f = bin_frequencies(g.nt, g.dt_s)
    v = gen.variances["u"]
    a = xu[:, :, 0, 0]
    for (iy, iz) in [(1, 0), (2, 0), (4, 0), (0, 2), (3, 2)]:
        r = np.hypot(iy * g.dy_m, iz * g.dz_m)
        for lo, hi in [(0.02, 0.06), (0.06, 0.15), (0.15, 0.4)]:
            k = np.flatnonzero((f >= lo) & (f < hi))
            target = float((v[k] * exponential_yz(r, f[k], U, KP.a_yz, KP.lc_m)).sum() / v[k].sum())
            _coherence_check(a, xu[:, :, iy, iz], v, k, target, f"r={r:.1f} m, {lo}-{hi} Hz")


def test_vw_white_by_default_and_coherent_as_option():
    x = tuple(float(i) * 1000 for i in range(4))
    g = Grid(1024, 0.5, x, 2, 1, 5.0, 5.0)
    f = bin_frequencies(g.nt, g.dt_s)
    k = np.flatnonzero((f > 0.02) & (f < 0.3))
    for coherent in (False, True):
        gen = KaimalEvo(KP, g, U, 2, long_coherence=_independent_planes, coherent_vw=coherent)
        for c in "vw":
            xc = _coefs(_field(gen, c))
            v = gen.variances[c]
            coh = exponential_yz(5.0, f[k], U, KP.a_yz, KP.lc_m) if coherent else np.zeros(k.size)
            target = float((v[k] * coh).sum() / v[k].sum())
            _coherence_check(xc[:, :, 0, 0], xc[:, :, 1, 0], v, k, target, f"{c} coherent={coherent}")


# -- longitudinal coherence -------------------------------------------------------------------------
SIGMA_TOTAL = float(np.sqrt(sum(s * s for s in KP.sigma_m_s)))
MODELS = {
    "exp": EXP,
    "simley-pao": partial(simley_pao, U_m_s=U, sigma_total_m_s=SIGMA_TOTAL, length_u_m=KP.length_scales_m[0]),
    "kristensen": partial(kristensen, U_m_s=U, sigma_total_m_s=SIGMA_TOTAL, length_u_m=KP.length_scales_m[0]),
}


@pytest.mark.parametrize("model", list(MODELS))
def test_longitudinal_coherence_between_planes_and_zero_phase(model):
    """u between planes: coherence = the model's un-squared gamma_x, zero phase; v, w independent."""
    white_yz = KaimalParams(KP.sigma_m_s, KP.length_scales_m, a_yz=1e4, lc_m=KP.lc_m)  # yz points independent
    g = Grid(2048, 0.5, (0.0, 40.0, 100.0), 4, 4, 5.0, 5.0)
    gen = KaimalEvo(white_yz, g, U, 7, long_coherence=MODELS[model])
    f = bin_frequencies(g.nt, g.dt_s)
    for c in "uv":
        xc = _coefs(_field(gen, c)).transpose(0, 2, 3, 1).reshape(g.nx, -1, f.size)  # (plane, point, bin)
        v = gen.variances[c]
        for p, q in [(0, 1), (0, 2), (1, 2)]:
            dx = abs(g.x_m[p] - g.x_m[q])
            for lo, hi in [(0.005, 0.03), (0.03, 0.1), (0.1, 0.3)]:
                k = np.flatnonzero((f >= lo) & (f < hi))
                gam = MODELS[model](dx, f[k]) if c == "u" else np.zeros(k.size)
                target = float((v[k] * gam).sum() / v[k].sum())
                _coherence_check(xc[p], xc[q], v, k, target, f"{model} {c} dx={dx} {lo}-{hi} Hz")


def test_bin_k_uses_coherence_of_k_df_not_k_plus_one():
    """evoTurb's off-by-one (bin k mixed with gamma_x((k+1) df)) is absent.

    df = 1/32 Hz, b_x = 0, a_x dx df / (2 U) = 0.5: gamma_x(k df) = exp(-k/2), so bins 1..4 have
    coherence 0.61, 0.37, 0.22, 0.14 (each checked within Z sd). The off-by-one values 0.37, 0.22
    of bins 1 and 2 are 28 and 11 sd away with 2304 independent points (v is white in yz, mixed via
    "uvw"): more than 2 Z, so an estimate within Z sd of the right value is more than Z sd from the
    wrong one, and the check cannot pass or fail by chance. (Bins 3-4 are only 6 and 4 sd apart.)
    """
    a_x = 0.5 * 2 * U / (100.0 / 32.0)
    gam = partial(exponential_longitudinal, U_m_s=U, a_x=a_x, b_x=0.0)
    g = Grid(64, 0.5, (0.0, 100.0), 48, 48, 5.0, 5.0)
    gen = KaimalEvo(KP, g, U, 11, long_coherence=gam, long_components="uvw")
    xv = _coefs(_field(gen, "v")).reshape(2, 64 // 2 + 1, -1)  # (plane, bin, point)
    for k in range(1, 5):
        a, b = xv[0, k], xv[1, k]
        c = (a * b.conj()).sum() / np.sqrt((np.abs(a) ** 2).sum() * (np.abs(b) ** 2).sum())
        right, wrong = np.exp(-k / 2), np.exp(-(k + 1) / 2)
        # sample coherence of n complex pairs: sd of Re c ~ (1 - rho^2) / sqrt(2 n)
        sd = (1 - right**2) / np.sqrt(2 * a.size)
        assert abs(c.real - right) < Z * sd + (1 - right**2) / a.size, (k, c, right)
        if abs(right - wrong) > 2 * Z * sd:
            assert abs(c.real - wrong) > Z * sd, (k, c, wrong)
        else:
            assert k > 2, "bins 1 and 2 must be separated by more than 2 Z sd"


# -- variance -------------------------------------------------------------------------------------
def test_sigma_matches_band_limited_targets_and_rescale():
    g = Grid(4096, 0.5, (0.0, 40.0, 100.0), 6, 6, 10.0, 10.0)
    gen = KaimalEvo(KP, g, U, 13, long_coherence=EXP)
    df = 1 / (g.nt * g.dt_s)
    f = bin_frequencies(g.nt, g.dt_s)
    yz = grid_distances(g.ny, g.nz, g.dy_m, g.dz_m)
    dx = np.abs(np.subtract.outer(g.x(), g.x()))
    n_pts = g.nx * g.ny * g.nz
    for i, c in enumerate("uvw"):
        target = kaimal_band_variance(df / 2, 1 / (2 * g.dt_s), KP.sigma_m_s[i], KP.length_scales_m[i], U)
        assert gen.expected_variance(c) == pytest.approx(target, rel=1e-12)
        assert target < KP.sigma_m_s[i] ** 2  # the resolved band misses the tail above 1 Hz
        v = gen.variances[c]
        if c == "u":
            s2 = np.array([(EXP(dx, fk) ** 2).sum() * (exponential_yz(yz, fk, U) ** 2).sum() for fk in f])
        else:
            s2 = np.full(f.size, float(n_pts))
        s2[-1] *= 2  # real Nyquist coefficient
        sd = np.sqrt((v**2 * s2).sum()) / n_pts
        realised = float((_field(gen, c).astype(np.float64) ** 2).mean())
        assert abs(realised - target) < Z * sd, (c, realised, target, sd)
    rescaled = KaimalEvo(KP, g, U, 13, long_coherence=EXP, rescale=True)
    for i, c in enumerate("uvw"):
        assert rescaled.expected_variance(c) == pytest.approx(KP.sigma_m_s[i] ** 2, rel=1e-12)


def test_zero_mean_and_float32():
    g = Grid(256, 0.5, (0.0, 50.0), 3, 3, 5.0, 5.0)
    x = _field(KaimalEvo(KP, g, U, 1, long_coherence=EXP), "u")
    assert x.dtype == np.float32
    np.testing.assert_allclose(x.astype(np.float64).mean(axis=1), 0.0, atol=1e-5 * float(x.std()))


# -- determinism ----------------------------------------------------------------------------------
def test_deterministic_across_threads_and_seed_sensitive():
    g = Grid(4 * FREQ_CHUNK + 6, 0.5, (0.0, 50.0, 90.0), 5, 4, 5.0, 5.0)  # odd nt, partial last chunk
    one = [_field(KaimalEvo(KP, g, U, 21, long_coherence=EXP, workers=w), "u") for w in (1, 2)]
    assert np.array_equal(one[0], one[1])
    other = _field(KaimalEvo(KP, g, U, 22, long_coherence=EXP), "u")
    assert not np.array_equal(one[0], other)


def test_plane_ring_gives_the_same_planes_to_a_consumer_one_plane_behind():
    """With a PlaneRing the planes of u, v, w (read as the runs layer reads them: plane k is used up when plane k + 1
    arrives) are those made in fresh arrays, bit for bit, from 4 buffers reused over the components."""
    g = Grid(3 * FREQ_CHUNK, 0.5, (0.0, 20.0, 40.0, 60.0, 80.0, 100.0), 4, 3, 5.0, 5.0)
    fresh = {c: _field(KaimalEvo(KP, g, U, 4, long_coherence=EXP), c) for c in "uvw"}
    ring, gen, seen, buffers = PlaneRing(g.nt, g.ny, g.nz), KaimalEvo(KP, g, U, 4, long_coherence=EXP), {}, set()
    previous = None
    for c in "uvw":
        for ix, plane in gen.component_planes(c, ring=ring):
            if previous is not None:  # the consumer is one plane behind, as run_kaimal's background write
                seen[previous[0]] = previous[1].copy()
            previous = ((c, ix), plane)
            buffers.add(plane.__array_interface__["data"][0])
    seen[previous[0]] = previous[1].copy()
    assert len(buffers) == ring.size == 4
    touched = PlaneRing(g.nt, g.ny, g.nz, 5)
    touched.touch()  # all planes made (and written once) up front; take() then hands out the same ones in turn
    planes = [touched.take() for _ in range(10)]
    assert len({p.__array_interface__["data"][0] for p in planes}) == 5 and planes[0] is planes[5]
    assert not np.any(planes[0])
    for c in "uvw":
        np.testing.assert_array_equal(np.stack([seen[(c, ix)] for ix in range(g.nx)]), fresh[c])


@pytest.mark.parametrize("nt,ny,nz", [(4096, 31, 31), (256, 5, 3), (255, 4, 1)])
def test_blocked_inverse_transform_is_the_whole_array_irfft(nt, ny, nz):
    """inverse_transform (column blocks, amplitudes applied in the block copy) equals scipy's irfft of the
    scaled spectrum bit for bit, and numpy's irfft (an independent FFT) to float32 rounding."""
    import scipy.fft

    rng = np.random.default_rng(5)
    nf = nt // 2 + 1
    spec = (rng.standard_normal((nf, ny, nz)) + 1j * rng.standard_normal((nf, ny, nz))).astype(np.complex64)
    amp = rng.random(nf).astype(np.float32)
    scaled = spec * amp[:, None, None]
    got = inverse_transform(spec, amp, nt)
    into = np.full((nt, ny, nz), np.nan, dtype=np.float32)
    assert inverse_transform(spec, amp, nt, out=into) is not None
    np.testing.assert_array_equal(into, got)  # the same values written into a given array
    assert got.dtype == np.float32 and got.shape == (nt, ny, nz)
    np.testing.assert_array_equal(got, scipy.fft.irfft(scaled, n=nt, axis=0, norm="forward"))
    reference = np.fft.irfft(scaled.astype(np.complex128), n=nt, axis=0, norm="forward")
    # float32 FFT rounding grows like eps log2(nt) times the rms (observed about half of eps log2(nt) here);
    # a factor 4 above that bound
    eps = float(np.finfo(np.float32).eps)
    np.testing.assert_allclose(got, reference, rtol=0, atol=4 * eps * np.log2(nt) * reference.std())
