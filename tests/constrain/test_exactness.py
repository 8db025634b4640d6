"""Exactness of the fast conditioning path (turbgen.synthesis.conditioning) against dense Gaussian conditioning on
the prior covariance measured from the generator itself (tests/constrain/brute_force.py), on tiny grids.

Tolerances: the brute-force covariance comes from float32 fields (relative round-off ~1e-7 of the largest
variance); the fast path works in float64 from the same float32 stencil. Gains are compared relative to their
largest entry at 1e-5 (the float32 round-off amplified by the condition number of S, < 1e2 here).
"""

from __future__ import annotations

import numpy as np
import pytest

from brute_force import dense_gain, generator_covariance
from turbgen.errors import ParameterError
from turbgen import fft
from turbgen.synthesis.conditioning import (Streams, check_singular, circulant_apply, correction_blocks, measure,
                                            measure_spectra, measured_points, solve, spectra_samples,
                                            stream_covariance)  # fmt: skip
from turbgen.synthesis.mann_spacetime import MannSnapshots
from turbgen.synthesis.mann_stencil import BoxShape, build_stencil
from turbgen.theory.params import MannParams

NY = NZ = 2
BOX = BoxShape(16, 10.0, 4, 4, 10.0, 10.0)


def weights_field(stencil, streams, weights, times_s, plane, ny, nz):
    """C H^T w on plane ``plane``, cropped to ny x nz: (3, nt, ny, nz) float64, from correction_blocks' spectra."""
    spectra = np.empty((3, stencil.box.nk1, ny, nz), np.complex64)
    for slabs, block in correction_blocks(stencil, streams, weights, times_s, [plane], ny, nz):
        spectra[:, slabs.start : slabs.stop] = block[0]
    return fft.oneshot().irfft(spectra.astype(complex), n=stencil.box.nt, axis=-3) * stencil.box.nt


def _setup(evo, times):
    params = MannParams(ae=1.0, length_scale_m=30.0, gamma=3.1, evo_time_s=evo)
    stencil = build_stencil(params, BOX, evolving=evo is not None)
    with pytest.MonkeyPatch.context() as mp:
        cov = generator_covariance(mp, stencil, NY, NZ, times)
    return stencil, np.asarray(times, float), cov


@pytest.fixture(scope="module")
def frozen():
    return _setup(None, [0.0])


@pytest.fixture(scope="module")
def evolving():
    return _setup(20.0, [0.0, 2.0, 5.0])


def _streams(n_planes, scanned=False):
    # u at (0, 1) of the first plane; w bilinear between (0, 0) and (1, 0) of the last plane; a projection
    # 0.6 u + 0.8 v at (1, 1) of the middle plane. ``scanned``: as a lidar's beam-gates, observed every 4th time
    # step from offsets 1, 3, 0, terms ahead in time by 0, 2, 5, 1, 3 steps (probe points along the beam)
    last, mid = n_planes - 1, n_planes // 2
    if scanned:
        return Streams(np.array([0, last, mid]), np.array([0, 1, 1, 2, 2]), np.array([0, 2, 2, 0, 1]),
                       np.array([0, 0, 1, 1, 1]), np.array([1, 0, 0, 1, 1]), np.array([1.0, 0.3, 0.7, 0.6, 0.8]),
                       ("a", "b", "c"), term_shift=np.array([0, 2, 5, 1, 3]), decimation=4,
                       offset=np.array([1, 3, 0]))  # fmt: skip
    return Streams(
        plane=np.array([0, last, mid]),
        term_stream=np.array([0, 1, 1, 2, 2]),
        term_component=np.array([0, 2, 2, 0, 1]),
        term_iy=np.array([0, 0, 1, 1, 1]),
        term_iz=np.array([1, 0, 0, 1, 1]),
        term_weight=np.array([1.0, 0.3, 0.7, 0.6, 0.8]),
        names=("a", "b", "c"),
    )


def _four_direction_streams(n_planes):
    """Streams along four directions (ten direction pairs: S is built from Phi's components): u at (0, 1) of the first
    plane, 0.6 u + 0.8 v at (1, 1) of the middle one, 0.6 u - 0.8 w bilinear between (0, 0) and (1, 0) of the last,
    0.48 u - 0.6 v + 0.64 w at (1, 0) of the first."""
    last, mid = n_planes - 1, n_planes // 2
    terms = [(0, 0, 0, 1, 1.0), (1, 0, 1, 1, 0.6), (1, 1, 1, 1, 0.8), (2, 0, 0, 0, 0.18), (2, 2, 0, 0, -0.24),
             (2, 0, 1, 0, 0.42), (2, 2, 1, 0, -0.56), (3, 0, 1, 0, 0.48), (3, 1, 1, 0, -0.6), (3, 2, 1, 0, 0.64)]
    stream, comp, iy, iz, weight = (np.array(v) for v in zip(*terms))
    return Streams(np.array([0, mid, last, 0]), stream, comp, iy, iz, weight.astype(float), ("a", "b", "c", "d"))


def _dense_h(streams, n_planes, nt):
    """H (M nt/q, N) on the field flattened as (plane, component, t, y, z), by applying measure() to unit fields."""
    n = n_planes * 3 * nt * NY * NZ
    n_dec = nt // streams.decimation
    h = np.zeros((streams.n_streams * n_dec, n))
    for col in range(n):
        p, c, rest = col // (3 * nt * NY * NZ), (col // (nt * NY * NZ)) % 3, col % (nt * NY * NZ)
        field = np.zeros(nt * NY * NZ)
        field[rest] = 1.0
        out = np.zeros((streams.n_streams, n_dec))
        measure(streams, p, c, field.reshape(nt, NY, NZ), out)
        h[:, col] = out.ravel()
    return h


def _fast_gain(stencil, streams, times, noise_var, observed):
    cov = stream_covariance(stencil, streams, times, noise_var)
    cols, iterations = [], []
    for k in np.flatnonzero(observed.ravel()):
        r = np.zeros(observed.size)
        r[k] = 1.0
        x, report = solve(cov, r.reshape(observed.shape), observed)
        iterations.append(report.iterations)
        assert report.relative_residual <= 1e-9
        field = [weights_field(stencil, streams, x, times, p, NY, NZ) for p in range(len(times))]
        cols.append(np.ravel(field))
    return np.array(cols).T, iterations


@pytest.mark.parametrize("case", ["frozen", "evolving"])
@pytest.mark.parametrize("gaps", [False, True])
@pytest.mark.parametrize("scanned", [False, True])
def test_gain_and_conditional_covariance_match_dense_conditioning(case, gaps, scanned, request):
    stencil, times, cov = request.getfixturevalue(case)
    streams = _streams(len(times), scanned)
    nt = BOX.nt
    n_dec = nt // streams.decimation
    h = _dense_h(streams, len(times), nt)
    noise = np.array([0.01, 0.0, 0.04])
    observed = np.ones((3, n_dec), bool)
    if gaps:
        observed[0, 1:3] = False
        observed[2, n_dec - 1] = False
    keep = observed.ravel()
    k_fast, iterations = _fast_gain(stencil, streams, times, noise, observed)
    k_ref = dense_gain(cov, h[keep], np.repeat(noise, n_dec)[keep])
    np.testing.assert_allclose(k_fast, k_ref, rtol=0, atol=1e-5 * np.abs(k_ref).max())
    if gaps:
        assert max(iterations) > 0  # the gaps were solved by the conjugate gradients
    # conditional covariance of the sample u_s + K (d - H u_s - eps_s): (I - K H) C (I - K H)^T + K R K^T
    ikh = np.eye(len(cov)) - k_fast @ h[keep]
    post_fast = ikh @ cov @ ikh.T + k_fast @ np.diag(np.repeat(noise, n_dec)[keep]) @ k_fast.T
    post_ref = cov - k_ref @ h[keep] @ cov
    np.testing.assert_allclose(post_fast, post_ref, rtol=0, atol=1e-5 * np.abs(cov).max())


@pytest.mark.parametrize("scanned", [False, True])
def test_zero_noise_reproduces_the_data(evolving, scanned):
    stencil, times, cov = evolving
    streams = _streams(len(times), scanned)
    n_dec = BOX.nt // streams.decimation
    cov_s = stream_covariance(stencil, streams, times, np.zeros(3))
    d = np.random.default_rng(5).normal(size=(3, n_dec))
    x, _ = solve(cov_s, d, np.ones((3, n_dec), bool))
    remeasured = np.zeros((3, n_dec))
    for p in range(len(times)):
        field = weights_field(stencil, streams, x, times, p, NY, NZ)
        for c in range(3):
            measure(streams, p, c, field[c], remeasured)
    # the correction's spectra are held in complex64 (the field is float32): ~1e-7 of the data's size
    np.testing.assert_allclose(remeasured, d, rtol=0, atol=1e-6)


def test_dependent_zero_noise_measurements_are_refused(frozen):
    stencil, times, _ = frozen
    s = _streams(1)
    twice = Streams(np.array([0, 0]), np.array([0, 1]), np.array([0, 0]), np.array([0, 0]), np.array([1, 1]),
                    np.array([1.0, 1.0]), ("mast.json u", "copy.json u"))
    with pytest.raises(ParameterError, match="mast.json u, copy.json u are linearly dependent"):
        check_singular(stream_covariance(stencil, twice, times, np.zeros(2)), twice.names)
    check_singular(stream_covariance(stencil, s, times, np.zeros(3)), s.names)  # independent: no error


@pytest.mark.parametrize("scanned", [False, True])
def test_thread_count_does_not_change_a_bit(evolving, scanned, monkeypatch):
    # slab groups run concurrently and are summed in slab order; groups of 2 slabs give several groups here
    import turbgen.synthesis.conditioning as cond

    monkeypatch.setattr(cond, "SLAB_GROUP", 2)
    stencil, times, _ = evolving
    streams = _streams(3, scanned)
    one, two = (cond.stream_covariance(stencil, streams, times, np.full(3, 0.01), threads=t) for t in (1, 2))
    np.testing.assert_array_equal(one, two)
    w = np.random.default_rng(5).normal(size=(3, BOX.nt // streams.decimation))
    blocks = [[b for _, b in cond.correction_blocks(stencil, streams, w, times, [0, 1, 2], NY, NZ, threads=t)]
              for t in (1, 2)]  # fmt: skip
    assert len(blocks[0]) > 1
    for a, b in zip(*blocks):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("scanned", [False, True])
def test_spectral_measurement_equals_measuring_the_field(evolving, scanned):
    """Pass 1 measures the snapshots' spectra (measure_spectra, spectra_samples): the same H u as measure() on the
    generated planes, to float32 round-off of the field (the field's own transform is float32)."""
    stencil, times, _ = evolving
    streams = _streams(len(times), scanned)
    gen = MannSnapshots(stencil, NY, NZ, threads=1)
    nt = stencil.box.nt
    direct = np.zeros((streams.n_streams, nt // streams.decimation))
    for ix, comp, field in gen.generate(7, times):
        measure(streams, ix, "uvw".index(comp), field.astype(float), direct)
    spec = np.zeros((streams.n_streams, nt // 2 + 1), complex)
    order = np.argsort(times, kind="stable")
    for m, spectra in gen.spectra(7, times):
        measure_spectra(streams, int(order[m]), spectra, NZ, nt, spec)
    spectral = spectra_samples(streams, spec, nt)
    assert np.abs(spectral - direct).max() < 1e-5 * np.abs(direct).max()
    assert np.abs(direct).max() > 0
    # a generator keeping the measured points only (pass 1 of a constrained run): the same spectra there, bit for bit
    points = measured_points(streams, NZ)
    kept = MannSnapshots(stencil, NY, NZ, threads=1, points=points)
    from_points = np.zeros_like(spec)
    for (m, full), (_, part) in zip(gen.spectra(7, times), kept.spectra(7, times)):
        assert part.shape[1] == len(points) <= NY * NZ
        np.testing.assert_array_equal(part, full[:, points])
        measure_spectra(streams, int(order[m]), part, NZ, nt, from_points, points)
    np.testing.assert_array_equal(from_points, spec)
    with pytest.raises(ValueError, match="spectra only"):
        next(kept.generate(7, times))


def test_unconverged_conjugate_gradients_are_refused(evolving, monkeypatch):
    """Gaps: PCG stops at CG_MAX_ITERATIONS with one line naming the residual reached (here 1 iteration)."""
    import turbgen.synthesis.conditioning as conditioning

    stencil, times, _ = evolving
    streams = _streams(len(times))
    nt = stencil.box.nt
    cov = stream_covariance(stencil, streams, times, np.zeros(streams.n_streams))
    observed = np.ones((streams.n_streams, nt), bool)
    observed[0, ::3] = False
    r = np.random.default_rng(3).normal(size=observed.shape)
    x, report = solve(cov, r, observed)
    assert report.method == "pcg" and report.iterations > 1
    monkeypatch.setattr(conditioning, "CG_MAX_ITERATIONS", 1)
    with pytest.raises(ParameterError, match=r"did not converge in 1 conjugate-gradient iterations \(relative residual"):
        solve(cov, r, observed)


@pytest.mark.parametrize("gap_start", [False, True])
def test_solve_with_gaps_equals_the_dense_solve(evolving, monkeypatch, gap_start):
    """S_oo x = r with 30 % of the samples missing at random, by conjugate gradients from zero or from the
    precision-matrix start (_gap_start, forced either way): the dense solve of S restricted to the observed samples
    (S built column by column from circulant_apply) to the solver's tolerance times cond(S_oo)."""
    import turbgen.synthesis.conditioning as conditioning

    stencil, times, _ = evolving
    streams = _streams(len(times))
    nt = stencil.box.nt
    cov = stream_covariance(stencil, streams, times, np.zeros(streams.n_streams))
    shape = (streams.n_streams, nt)
    dense = _circulant_dense(cov, shape)
    rng = np.random.default_rng(4)
    observed = rng.random(shape) >= 0.3
    r = np.where(observed, rng.normal(size=shape), 0.0)
    o = observed.ravel()
    expect = np.zeros(o.size)
    expect[o] = np.linalg.solve(dense[np.ix_(o, o)], r.ravel()[o])
    monkeypatch.setattr(conditioning, "GAP_START_FRACTION", 0.0 if gap_start else 1.0)
    x, report = solve(cov, r, observed)
    bound = 10 * conditioning.CG_TOLERANCE * np.linalg.cond(dense[np.ix_(o, o)])
    assert report.method == "pcg" and report.relative_residual <= conditioning.CG_TOLERANCE
    assert np.abs(x.ravel() - expect).max() <= bound * np.abs(expect).max(), (report, bound)
    if gap_start:  # the start alone is the solution to its inner tolerance (1e-12) times the conditioning
        start, _ = conditioning._gap_start(np.linalg.inv(cov[: nt // 2 + 1]), r, observed)
        assert np.abs(start.ravel() - expect).max() <= 1e2 * bound * np.abs(expect).max()


def _circulant_dense(cov, shape):
    return np.stack([circulant_apply(cov, e.reshape(shape)).ravel() for e in np.eye(np.prod(shape))], 1)


@pytest.mark.parametrize("case", ["frozen", "evolving"])
def test_phis_components_give_h_c_ht_plus_r(case, request):
    """Four directions: S from Phi's six components (even and odd in k2, the transform along y halved by the
    parity: _component_basis, _LagTransform) equals H C H^T + R of the dense prior (built from the float32
    generator: its round-off, ~1e-7 relative, is the tolerance's scale)."""
    import turbgen.synthesis.conditioning as conditioning

    stencil, times, cov = request.getfixturevalue(case)
    streams = _four_direction_streams(len(times))
    assert conditioning._basis(conditioning._keys(streams).directions).n_even == conditioning.N_EVEN  # components
    noise = np.full(streams.n_streams, 0.01)
    fast = _circulant_dense(stream_covariance(stencil, streams, times, noise), (streams.n_streams, BOX.nt))
    h = _dense_h(streams, len(times), BOX.nt)
    ref = h @ cov @ h.T + np.diag(np.repeat(noise, BOX.nt))
    assert np.abs(fast - ref).max() <= 1e-6 * np.abs(ref).max()


@pytest.mark.parametrize("ny_box", [4, 5])
def test_phis_components_equal_the_direction_pairs(ny_box, monkeypatch):
    """The component basis (with the parity for an even box width, without it for an odd one) and the direction
    pairs' own transforms (forced) give the same S to round-off, the k1 = 0 and Nyquist slabs included."""
    import turbgen.synthesis.conditioning as conditioning

    params = MannParams(ae=1.0, length_scale_m=30.0, gamma=3.1, evo_time_s=20.0)
    stencil = build_stencil(params, BoxShape(16, 10.0, ny_box, 4, 10.0, 10.0), evolving=True)
    times = np.array([0.0, 2.0, 5.0])
    streams = _four_direction_streams(len(times))
    noise = np.zeros(streams.n_streams)
    components = stream_covariance(stencil, streams, times, noise)
    monkeypatch.setattr(conditioning, "_basis", conditioning._direction_basis)
    pairs = stream_covariance(stencil, streams, times, noise)
    assert np.abs(components - pairs).max() <= 1e-13 * np.abs(pairs).max()


@pytest.mark.parametrize("order", ["given", "reversed"])
def test_dependent_set_is_the_smallest_one_whatever_the_round_off(order):
    """Measurement 5 = 2 m1 - m3 (complex covariances of 8 measurements): the named set is {1, 3, 5} in the given
    order ({2, 4, 6} reversed), and perturbing S by 1e-13 relative (the size of another BLAS kernel's round-off) in
    200 draws never changes it: the decision has margins of >= 1e5 on either side."""
    from turbgen.synthesis.conditioning import dependent_set

    rng = np.random.default_rng(7)
    h = rng.standard_normal((8, 12)) + 1j * rng.standard_normal((8, 12))
    h[5] = 2 * h[1] - h[3]
    want = [1, 3, 5]
    if order == "reversed":
        h, want = h[::-1], [2, 4, 6]
    s = h @ h.conj().T
    assert dependent_set(s) == want
    for _ in range(200):
        e = rng.standard_normal(s.shape) * 1e-13 * np.abs(s).max()
        assert dependent_set(s + (e + e.T) / 2) == want
    assert dependent_set(np.diag([1.0, 0.0, 2.0]).astype(complex)) == [1]  # no variance: dependent by itself
