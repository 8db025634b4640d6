"""2-D circulant embedding: exact covariance on small grids, the adaptive torus, fallbacks, clipping report."""

from __future__ import annotations

import math

import numpy as np
import pytest

from turbgen.synthesis import circulant
from turbgen.synthesis.circulant import embed, fft_size, grid_distances, torus_size, wrapped_distance
from turbgen.theory.coherence_models import exponential_yz

U, A_YZ, LC = 16.0, 12.0, 340.2
# a torus shorter than 2 (N - 1) wraps lags where the kernel is below exp(-CUTOFF_DECAYS) (4e-8, under the float32
# rounding of the scales the generator samples with): each lag takes at most one such image per axis and corner
WRAP_TOL = 3 * math.exp(-circulant.CUTOFF_DECAYS) + 1e-12


def _kernel(f_hz):
    return lambda r: exponential_yz(r, f_hz, U, A_YZ, LC)


def _decay(f_hz):
    return 1.0 / (A_YZ * np.hypot(f_hz / U, 0.12 / LC))


def _linear_map(e):
    """Matrix A (N x M) of the sampler: Z = A xi, found by sampling every unit vector in complex128."""
    my, mz = e.torus_shape
    eye = np.eye(my * mz, dtype=np.complex128).reshape(my * mz, my, mz)
    z = e.sample(eye)  # (M, ny, nz)
    return z.reshape(my * mz, -1).T


@pytest.mark.parametrize("ny,nz,dy,dz,f", [(5, 4, 3.0, 4.0, 0.3), (4, 4, 5.0, 5.0, 0.1), (7, 1, 10.0, 1.0, 0.5)])
def test_sampler_reproduces_covariance_exactly(ny, nz, dy, dz, f):
    """The sampler's map A (Z = A xi, xi circular): A A^H equals C and the dense Cholesky L L^T (to rounding)."""
    e = embed(_kernel(f), ny, nz, dy, dz, _decay(f), dense_when_cheaper=False)  # the torus itself
    assert e.chol is None and e.clip_error == 0.0
    a = _linear_map(e)
    c = _kernel(f)(grid_distances(ny, nz, dy, dz))
    chol = np.linalg.cholesky(c)
    np.testing.assert_allclose(a @ a.conj().T, c, atol=WRAP_TOL, rtol=0)
    np.testing.assert_allclose(a @ a.conj().T, chol @ chol.T, atol=WRAP_TOL, rtol=0)


def _corner_covariance(e):
    """Covariance of the sampler's output between the corner origin and every corner point.

    Z = FFT2(s xi) with independent xi gives cov(Z_a, Z_b) = sum_j s_j^2 w^(j (a - b)) = FFT2(s^2)[a - b].
    """
    return np.fft.fft2(e.scale**2)[: e.ny, : e.nz].real


@pytest.mark.parametrize("f", [1 / 2048, 4 / 2048, 0.02, 0.05, 0.3, 1.0])
def test_adaptive_torus_is_exact_on_the_paper_grid(f):
    """31 x 31 at 5 m: every lag of the realised covariance equals coh(r, f) (eigenvalues all >= 0): to rounding
    where the torus holds every lag (classical at least 2 (N - 1), or with the smooth cut-off), to WRAP_TOL where a
    short torus wraps the negligible tail (high f)."""
    e = embed(_kernel(f), 31, 31, 5.0, 5.0, _decay(f))
    assert e.chol is None and e.clip_error == 0.0 and e.enlarged == 0
    r = np.hypot(*np.meshgrid(np.arange(31) * 5.0, np.arange(31) * 5.0, indexing="ij"))
    tol = 1e-12 if min(e.torus_shape) >= 60 else WRAP_TOL
    np.testing.assert_allclose(_corner_covariance(e), _kernel(f)(r), atol=tol, rtol=0)


def test_smooth_cutoff_keeps_every_grid_lag_and_vanishes_at_half_the_period():
    phi = circulant.smooth_cutoff(31, 5.0, 120)
    lag = np.minimum(np.arange(120), 120 - np.arange(120)) * 5.0
    assert np.all(phi[lag <= 150.0] == 1.0) and phi[60] == 0.0
    inside = (lag > 150.0) & (lag < 300.0)
    assert np.all((phi[inside] > 0) & (phi[inside] < 1))
    assert np.all(np.diff(phi[30:61]) <= 0)  # falls monotonically from the grid's largest lag to half the period


@pytest.mark.parametrize(
    "ny,nz,dy,dz", [(31, 31, 5.0, 5.0), (20, 8, 3.0, 7.0), (64, 64, 2.5, 2.5), (11, 40, 10.0, 2.0)]
)
@pytest.mark.parametrize("f", [1 / 2048, 1 / 256, 0.01])
def test_smooth_cutoff_torus_is_exact_and_smaller(ny, nz, dy, dz, f):
    """Low frequencies (the kernel high across the grid): the smooth cut-off's torus needs no enlarging, realises C on
    every lag to rounding and holds fewer points than the classical 12-decay-length torus."""
    my, mz, smooth = circulant.torus_plan(ny, nz, dy, dz, _decay(f))
    assert smooth and my * mz < torus_size(ny, dy, _decay(f)) * torus_size(nz, dz, _decay(f))
    e = embed(_kernel(f), ny, nz, dy, dz, _decay(f), dense_when_cheaper=False)
    assert e.chol is None and e.clip_error == 0.0 and e.enlarged == 0 and e.torus_shape == (my, mz)
    r = np.hypot(*np.meshgrid(np.arange(ny) * dy, np.arange(nz) * dz, indexing="ij"))
    np.testing.assert_allclose(_corner_covariance(e), _kernel(f)(r), atol=1e-12, rtol=0)


def test_smooth_cutoff_cuts_the_lowest_bins_torus_of_the_paper_grid():
    """f = df of the default Kaimal field: 5 decay lengths beyond twice the grid instead of 12 decay lengths."""
    d = _decay(1 / 2048)
    my, mz, smooth = circulant.torus_plan(31, 31, 5.0, 5.0, d)
    assert smooth and my * 5.0 >= 300.0 + 5 * d and torus_size(31, 5.0, d) ** 2 > 3.5 * my * mz  # 567^2 vs 297^2


def test_minimal_torus_fails_at_low_frequency():
    """The M = 2(N - 1) torus has negative eigenvalues at f = df on the paper grid (why the torus adapts)."""
    f = 1 / 2048
    lam = np.fft.fft2(_kernel(f)(wrapped_distance(31, 31, 5.0, 5.0, 60, 60))).real
    assert lam.min() < -1e-3 * lam.max()
    assert embed(_kernel(f), 31, 31, 5.0, 5.0, _decay(f)).torus_shape[0] >= 60 + 5 * _decay(f) / 5.0  # smooth cut-off


def test_torus_rule_and_fft_sizes():
    for n in (1, 7, 60, 97, 121, 565):
        m = fft_size(n)
        assert m >= n and all(p in (2, 3, 5, 7, 11) for p in _prime_factors(m))  # pocketfft sizes
    assert torus_size(1, 5.0, 1e9) == 1
    assert torus_size(31, 5.0, 10.0) == 60  # 2 (N - 1) ...
    assert torus_size(31, 5.0, 1.0) == 35  # ... unless the kernel is < 4e-8 beyond 17 decay lengths = 4 points
    assert torus_size(31, 5.0, 100.0) == fft_size(240)  # 12 decay lengths


def _prime_factors(m):
    out, p = [], 2
    while m > 1:
        while m % p == 0:
            out.append(p)
            m //= p
        p += 1
    return out


def _bad_kernel(r):
    """A distance kernel that is not positive definite in 2-D (strong negative lobe): forces the fallbacks."""
    return np.cos(np.asarray(r) / 3.0) * np.exp(-np.asarray(r) / 50.0)


def test_enlarging_then_cholesky_fallback_is_exact(monkeypatch):
    """A kernel whose torus spectrum stays negative: small grids fall back to Cholesky of a PD C."""
    kernel = lambda r: np.exp(-np.asarray(r) / 50.0)  # noqa: E731 -- PD in 2-D, negative on the 10 x 8 torus
    monkeypatch.setattr(circulant, "MAX_ENLARGE", 0)
    monkeypatch.setattr(circulant, "torus_size", lambda n, h, d: 2 * (n - 1))
    e = embed(kernel, 6, 5, 4.0, 4.0, 50.0, dense_when_cheaper=False)
    assert e.chol is not None and e.clip_error == 0.0
    a = _linear_map(e)
    np.testing.assert_allclose(a @ a.conj().T, kernel(grid_distances(6, 5, 4.0, 4.0)), atol=1e-12)


def test_clipping_is_reported_and_bounds_the_error(monkeypatch):
    """Large grids clip negative eigenvalues: clip_error > 0 and >= the actual covariance error."""
    monkeypatch.setattr(circulant, "CHOLESKY_MAX_POINTS", 0)
    monkeypatch.setattr(circulant, "MAX_ENLARGE", 1)
    monkeypatch.setattr(circulant, "torus_size", lambda n, h, d: 2 * (n - 1))
    e = embed(_bad_kernel, 6, 6, 2.0, 2.0, 50.0)
    assert e.clip_error > 0
    a = _linear_map(e)
    err = np.abs(a @ a.conj().T - _bad_kernel(grid_distances(6, 6, 2.0, 2.0))).max()
    assert 0 < err <= e.clip_error + 1e-12


def test_in_place_sampling_gives_the_same_values():
    """sample(overwrite=True) (the generator's path: scale and FFT in the noise array) equals the copying
    sample bit for bit, for a batch of bins in complex64 as the Kaimal generator draws them."""
    f = 0.05
    e = embed(_kernel(f), 31, 31, 5.0, 5.0, _decay(f))
    batch = circulant.Embedding(31, 31, np.stack([e.scale, 0.5 * e.scale]).astype(np.float32), None, 0.0, 0)
    rng = np.random.default_rng(3)
    shape = (2, *e.torus_shape)
    xi = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(np.complex64)
    expected = batch.sample(xi, 1)
    work = xi.copy()
    got = batch.sample(work, 1, overwrite=True)
    assert got.dtype == np.complex64 and np.shares_memory(got, work)
    np.testing.assert_array_equal(got, expected)
    assert not np.array_equal(work, xi)  # the input was used as the work array


def test_a_torus_beyond_the_cap_becomes_a_dense_factor():
    """a_yz = 0.5 on a 5 x 5 grid at the lowest bin of a 256-sample record wants a 3312 x 3312 torus even with the
    cut-off (0.5 GB in a run): the dense factor instead, exact (F F^T = C)."""
    a_yz, f = 0.5, 1.0 / 128.0
    kernel = lambda r: exponential_yz(r, f, U, a_yz, LC)  # noqa: E731
    decay = 1.0 / (a_yz * np.hypot(f / U, 0.12 / LC))
    assert torus_size(5, 5.0, decay) ** 2 > circulant.MAX_TORUS_POINTS
    e = embed(kernel, 5, 5, 5.0, 5.0, decay, dense_when_cheaper=False)
    assert e.chol is not None and e.torus_shape == (25, 1)
    a = _linear_map(e)
    np.testing.assert_allclose(a @ a.conj().T, kernel(grid_distances(5, 5, 5.0, 5.0)), atol=1e-12, rtol=0)


def test_enlarging_stops_at_the_cap(monkeypatch):
    """The torus grown for negative eigenvalues is not grown beyond MAX_TORUS_POINTS either: dense factor."""
    monkeypatch.setattr(circulant, "MAX_TORUS_POINTS", 11 * 11)
    monkeypatch.setattr(circulant, "torus_size", lambda n, h, d: 2 * (n - 1))
    kernel = lambda r: np.exp(-np.asarray(r) / 50.0)  # noqa: E731 -- negative on the 10 x 8 torus (see above)
    e = embed(kernel, 6, 5, 4.0, 4.0, 50.0, dense_when_cheaper=False)
    assert e.chol is not None and e.clip_error == 0.0


def test_semi_definite_coherence_gets_an_eigen_factor():
    """A coherence of 1 everywhere (rank 1: no Cholesky factor) is sampled exactly through its eigenvectors."""
    e = circulant.dense_embedding(lambda r: np.ones_like(r), 3, 4, 5.0, 5.0)
    a = _linear_map(e)
    np.testing.assert_allclose(a @ a.conj().T, np.ones((12, 12)), atol=1e-12, rtol=0)
    assert e.clip_error <= 1e-12


@pytest.mark.parametrize("ny, a_yz, refused", [(5, 0.5, False), (64, 0.5, True), (64, 12.0, False)])
def test_sampling_cost_is_checked_before_anything_is_allocated(ny, a_yz, refused):
    from turbgen.errors import ParameterError

    freqs = np.arange(1, 129) / 128.0
    decays = 1.0 / (a_yz * np.hypot(freqs / U, 0.12 / LC))
    if refused:  # 4096 points: a dense factor is too large, the torus too
        with pytest.raises(ParameterError, match=r"a_yz.*lc_m"):
            circulant.check_sampling_cost(ny, ny, 5.0, 5.0, decays, "the yz coherence (a_yz = 0.5)")
    else:
        circulant.check_sampling_cost(ny, ny, 5.0, 5.0, decays, "the yz coherence")


def test_embed_many_equals_embed_bit_for_bit():
    """The batched embeddings (the Kaimal generator's path) are those of embed, bin by bin and bit for bit, on every
    torus kind: smooth cut-off, classical, wrapped (the default field's bins 1-2048 at nt 4096, dt 0.5 s), a dense
    factor beyond the cap and a torus that must be enlarged."""
    freqs = np.arange(1, 2049) / 2048.0
    kernels = [_kernel(f) for f in freqs]
    got = circulant.embed_many(kernels, 31, 31, 5.0, 5.0, [_decay(f) for f in freqs])
    for f, e in zip(freqs, got):
        want = embed(_kernel(f), 31, 31, 5.0, 5.0, _decay(f))
        assert e.chol is None and np.array_equal(e.scale, want.scale) and e.enlarged == want.enlarged == 0
    a_yz, f = 0.5, 1.0 / 128.0  # beyond the cap: a dense factor (test_a_torus_beyond_the_cap_becomes_a_dense_factor)
    far = lambda r: exponential_yz(r, f, U, a_yz, LC)  # noqa: E731
    (dense,) = circulant.embed_many([far], 5, 5, 5.0, 5.0, [1.0 / (a_yz * np.hypot(f / U, 0.12 / LC))],
                                    dense_when_cheaper=False)
    assert dense.chol is not None


def test_embed_many_enlarges_like_embed(monkeypatch):
    monkeypatch.setattr(circulant, "torus_size", lambda n, h, d: 2 * (n - 1))
    kernel = lambda r: np.exp(-np.asarray(r) / 50.0)  # noqa: E731 -- negative on the minimal 10 x 8 torus
    (got,) = circulant.embed_many([kernel], 6, 5, 4.0, 4.0, [math.inf], dense_when_cheaper=False)
    want = embed(kernel, 6, 5, 4.0, 4.0, math.inf, dense_when_cheaper=False)
    assert got.enlarged == want.enlarged > 0 and np.array_equal(got.scale, want.scale)


@pytest.mark.parametrize("f", [1 / 2048, 1 / 128])
def test_anisotropic_grid_enlarges_the_smooth_torus_by_one_decay_length(f):
    """A 3 x 40 grid needs 6 decay lengths beyond twice the grid, not 5: one enlarging step adds one decay length
    (not x1.5), the realised covariance is exact and the torus stays below the classical one."""
    e = embed(_kernel(f), 3, 40, 5.0, 5.0, _decay(f), dense_when_cheaper=False)
    assert e.enlarged == 1 and e.clip_error == 0.0 and e.chol is None
    my, mz = e.torus_shape
    assert my == circulant.smooth_torus_size(3, 5.0, _decay(f), 6.0)
    assert mz == circulant.smooth_torus_size(40, 5.0, _decay(f), 6.0)
    assert my * mz < torus_size(3, 5.0, _decay(f)) * torus_size(40, 5.0, _decay(f))
    r = np.hypot(*np.meshgrid(np.arange(3) * 5.0, np.arange(40) * 5.0, indexing="ij"))
    np.testing.assert_allclose(_corner_covariance(e), _kernel(f)(r), atol=1e-12, rtol=0)


def test_small_grids_take_a_dense_factor_where_it_is_cheaper_than_the_torus():
    """a_yz = 0.5 on 5 x 5 points: the tori below the cap (up to 1440 x 1440 points: 1.3 GB and 7.6 s for a
    default-length field; 44 bins beyond it took dense factors already) cost far more than a 25 x 25 factor, which
    embed and embed_many then take, exactly (F F^T = C); on the default 31 x 31 grid every bin keeps its torus (a
    961 x 961 factor costs more)."""
    a_yz = 0.5
    freqs = np.arange(1, 2049) / 2048.0
    decays = [1.0 / (a_yz * np.hypot(f / U, 0.12 / LC)) for f in freqs]
    kernels = [lambda r, f=f: exponential_yz(r, f, U, a_yz, LC) for f in freqs]
    plans = [circulant.torus_plan(5, 5, 5.0, 5.0, d) for d in decays]
    below_cap = [my * mz for my, mz, _ in plans if my * mz <= circulant.MAX_TORUS_POINTS]
    assert len(below_cap) > 2000 and max(below_cap) > 1400**2  # tori that used to be built
    assert all(circulant.dense_is_cheaper(25, my * mz) for my, mz, _ in plans)
    got = circulant.embed_many(kernels, 5, 5, 5.0, 5.0, decays)
    assert all(e.chol is not None and e.torus_shape == (25, 1) for e in got)
    a = _linear_map(got[0])
    np.testing.assert_allclose(a @ a.conj().T, kernels[0](grid_distances(5, 5, 5.0, 5.0)), atol=1e-12, rtol=0)
    default = circulant.embed_many([_kernel(f) for f in freqs], 31, 31, 5.0, 5.0, [_decay(f) for f in freqs])
    assert all(e.chol is None for e in default)


def test_dense_choice_is_the_same_in_embed_and_embed_many():
    """On a 6 x 6 grid the low bins take dense factors and the high ones tori: embed_many gives embed's choice and
    values bin by bin."""
    freqs = np.arange(1, 257) / 256.0
    got = circulant.embed_many([_kernel(f) for f in freqs], 6, 6, 5.0, 5.0, [_decay(f) for f in freqs])
    kinds = [e.chol is not None for e in got]
    assert any(kinds) and not all(kinds)
    for f, e in zip(freqs, got):
        want = embed(_kernel(f), 6, 6, 5.0, 5.0, _decay(f))
        assert (e.chol is None) == (want.chol is None)
        assert np.array_equal(e.chol, want.chol) if e.chol is not None else np.array_equal(e.scale, want.scale)
