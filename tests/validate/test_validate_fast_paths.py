"""The validator's fast paths equal their definitions: one-pass span sums, threads (theory alongside the
estimates, the verdict in two threads) giving the results of one thread."""

import numpy as np
import pytest
import scipy.fft

from turbgen.runs.mann import run_mann
from turbgen.spec.mann import MannRun
from turbgen.validation import theory_cache, validate
from turbgen.validation.estimators import WelchSetup, segment_starts
from turbgen.validation.pair_sums import (box_lags, half_lags, real_box_lags, rect_pair_counts, set_pair_counts,
                                          weighted_gram)
from turbgen.validation.span_sums import COMPONENTS, span_sums
from turbgen.validation.welch_sums import point_moments, window_segment


def test_span_sums_equal_the_definition():
    rng = np.random.default_rng(3)
    nt, ny, nz = 200, 7, 9
    data = {c: rng.standard_normal((nt, ny, nz)).astype(np.float32) + 1.5 for c in COMPONENTS}
    setup = WelchSetup(64, 0.5)
    seps = ((2, 0), (0, 3), (1, 2))
    mask = np.zeros((ny, nz), bool)
    mask[2:5, 3:7] = True
    iy, iz = np.array([1, 4]), np.array([0, 5, 8])
    starts = segment_starts(nt, setup)
    out = span_sums(data, setup.window, starts, seps, mask, iy, iz)
    # the definition in float64: per segment, the DFT of the mean-removed, windowed segment, and sums over
    # every point pair (y, z), (y + a, z + b) of the grid
    spec = {c: np.stack([scipy.fft.rfft((d[s : s + 64] - d[s : s + 64].mean(axis=0)) * setup.window[:, None, None],
                                        axis=0) for s in starts]) for c, d in data.items()}
    for c in COMPONENTS:
        x = spec[c]
        p = np.abs(x) ** 2
        auto = p.sum(axis=(0, 2, 3))
        # float32 data and FFT: relative rounding ~ 1e-7 per term, ~1e-6 after the FFT; 1e-5 of the scale of
        # each sum (sqrt(A B) bounds |cross|) leaves room for the summation order and nothing for a wrong pair
        np.testing.assert_allclose(out["auto"][c], auto, rtol=1e-5)
        for a, b in seps:
            cross = np.sum(np.conj(x[:, :, : ny - a, : nz - b]) * x[:, :, a:, b:], axis=(0, 2, 3))
            pa, pb = p[:, :, : ny - a, : nz - b].sum(axis=(0, 2, 3)), p[:, :, a:, b:].sum(axis=(0, 2, 3))
            got = out["yz"][c][(a, b)]
            np.testing.assert_allclose(got[1], pa, rtol=1e-5)
            np.testing.assert_allclose(got[2], pb, rtol=1e-5)
            assert np.all(np.abs(got[0] - cross) <= 1e-5 * np.sqrt(pa * pb))
        np.testing.assert_allclose(out["sum"][c], data[c].sum(axis=0, dtype=np.float64), rtol=1e-12)
        np.testing.assert_allclose(out["sum2"][c], (data[c].astype(np.float64) ** 2).sum(axis=0), rtol=1e-6)
    uw = np.sum(np.conj(spec["u"]) * spec["w"], axis=(0, 2, 3))
    assert np.all(np.abs(out["uw"] - uw) <= 1e-5 * np.sqrt(out["auto"]["u"] * out["auto"]["w"]))
    np.testing.assert_allclose(out["rews"], data["u"][:, mask].astype(np.float64).mean(axis=1), rtol=1e-6)
    sub = spec["u"][:, :, iy][:, :, :, iz].reshape(len(starts), 33, -1)
    np.testing.assert_allclose(out["sub"], sub, rtol=0, atol=1e-5 * np.abs(sub).max())


def test_point_moments_and_window_segment_equal_numpy():
    rng = np.random.default_rng(4)
    d = (rng.standard_normal((100, 5, 6)) + 3.0).astype(np.float32)
    mask_index = np.array([0, 3, 7, 8, 29])
    s, s2, blocks, masked = point_moments(d, mask_index, 16)
    x = d.astype(np.float64)
    np.testing.assert_allclose(s, x.sum(axis=0), rtol=1e-12)
    np.testing.assert_allclose(s2, (x**2).sum(axis=0), rtol=1e-12)
    np.testing.assert_allclose(blocks, x[:96].reshape(6, 16, 5, 6).sum(axis=1), rtol=1e-12)
    np.testing.assert_allclose(masked, x.reshape(100, -1)[:, mask_index].mean(axis=1), rtol=1e-12)
    w = WelchSetup(32, 0.5).window.astype(np.float32)
    out = np.empty((32, 5, 6), np.float32)
    mean = d[40:72].mean(axis=0)
    window_segment(d, 40, w, mean, out)
    # float32 data: the difference and the product rounded to float32 (relative 6e-8 each)
    np.testing.assert_allclose(out, (x[40:72] - mean) * w[:, None, None], rtol=0, atol=1e-6)


def test_pair_sums_equal_the_full_lag_grid():
    # half the lag grid (coh Hermitian in the lag, the counts symmetric) gives the sum over the whole grid
    rng = np.random.default_rng(5)
    ny, nz, nn, nyp, nzp = 6, 5, 7, 12, 10
    field = rng.standard_normal((nn, nyp, nzp))  # real spectrum: its transform is Hermitian in the lag
    coh = real_box_lags(field, ny, nz)
    np.testing.assert_allclose(coh, box_lags(np.fft.ifft2(field) * nyp * nzp, ny, nz), rtol=0, atol=1e-12)
    for counts in (rect_pair_counts(ny, nz, 4, 3), set_pair_counts(ny, nz, np.array([0, 2, 5]), np.array([1, 4]))):
        for c in (coh, coh.real + coh.real[:, ::-1, ::-1]):  # complex and real (symmetric) coherencies
            full = np.real(np.einsum("il,jl->ij", (c * counts).reshape(nn, -1), np.conj(c).reshape(nn, -1)))
            np.testing.assert_allclose(weighted_gram(half_lags(c), counts), full, rtol=1e-12, atol=1e-12)


@pytest.fixture(scope="module")
def mann_store(tmp_path_factory):
    path = tmp_path_factory.mktemp("fast") / "m.zarr"
    grid = {"nt": 1024, "x_m": [0.0, 40.0, 60.0], "ny": 10, "nz": 10, "dy_m": 8.0, "dz_m": 8.0}
    run_mann(MannRun.from_mapping({"grid": grid, "seed": 7}), path)
    return path


def test_threads_give_the_results_of_one_thread(mann_store):
    theory_cache.clear()
    one = validate(mann_store, workers=1)
    theory_cache.clear()  # the second computes its theory too, in its own thread
    two = validate(mann_store, workers=2)
    assert not one.seconds["theory_kept"] and not two.seconds["theory_kept"]
    a, b = one.to_dict(), two.to_dict()
    a.pop("seconds"), b.pop("seconds")
    assert a == b  # bit for bit: the same operations, only run alongside each other


def test_theory_is_kept_for_a_store_differing_only_in_seed(mann_store, tmp_path):
    other = tmp_path / "seed8.zarr"
    grid = {"nt": 1024, "x_m": [0.0, 40.0, 60.0], "ny": 10, "nz": 10, "dy_m": 8.0, "dz_m": 8.0}
    run_mann(MannRun.from_mapping({"grid": grid, "seed": 8}), other)
    theory_cache.clear()
    validate(mann_store, workers=2)
    kept = validate(other, workers=2)
    assert kept.seconds["theory_kept"]
    theory_cache.clear()
    fresh = validate(other, workers=2)
    assert not fresh.seconds["theory_kept"]
    a, b = kept.to_dict(), fresh.to_dict()
    a.pop("seconds"), b.pop("seconds")
    assert a == b  # the kept predictions are those of the store (and the verdict did not alter them)
    # another option or parameter is another entry
    assert not validate(other, workers=2, rotor_radius_m=30.0).seconds["theory_kept"]
    def key(seed, created, gamma):
        return theory_cache.theory_key("mann", {"seed": seed, "created_utc": created,
                                                "parameters": {"gamma": gamma, "seed": seed}})  # fmt: skip

    assert key(1, "x", 3.1) == key(2, "y", 3.1) != key(1, "x", 3.2)


@pytest.mark.parametrize("rank", [1, 3, None])
def test_top_modes_equal_the_full_eigenproblem_also_for_low_rank(rank):
    # a fully coherent plane (Kaimal a_yz = 0, allowed) has a rank-1 coherency matrix; the subspace
    # iteration's Cholesky QR failed on it ("Matrix is not positive definite") for N > 32 points.
    # rank None: a full-rank exponential coherence exp(-0.05 r) on a 5 x 10 grid, 4 m apart
    from turbgen.validation.variance_law import N_MODES, top_modes

    rng = np.random.default_rng(5)
    n = 50
    if rank is None:
        yz = 4.0 * np.stack(np.meshgrid(np.arange(5), np.arange(10)), -1).reshape(n, 2)
        c = np.exp(-0.05 * np.hypot(*(yz[:, None, :] - yz[None, :, :]).transpose(2, 0, 1))).astype(complex)
    else:
        a = rng.standard_normal((n, rank)) + 1j * rng.standard_normal((n, rank))
        c = a @ a.conj().T
        c /= np.mean(np.diag(c).real)  # unit mean diagonal, like a coherency matrix
    mu = np.clip(np.linalg.eigvalsh(c)[::-1][:N_MODES] / n, 0.0, None)
    got = top_modes(c)
    np.testing.assert_allclose(got[:N_MODES], mu, rtol=1e-6, atol=1e-12)
    assert got[-1] == pytest.approx(np.sum(np.abs(c) ** 2) / n**2)
