"""Mann space-time synthesis: stencil, exact discrete expectations, Hermitian trap, evolution, determinism.

The "discrete oracle" is exact for the synthesised field: u_hat(k) = C(k) n(k) with E|n|^2 = 2, so
E|u_hat_i(k)|^2 = 2 (C C^T)_ii(k) on every grid point (C from slab_factor, which the generator
uses). Statistical tolerances follow from the complex-Gaussian moments: for one mode,
Var|u_hat|^2 = s^2 with s = E|u_hat|^2, and |Re(a b*)| has variance <= (s_a s_b + |E a b*|^2) / 2;
sums over independent modes add variances; an average over N seeds divides them by N.
Bounds are Z_MAX = 4.5 standard deviations (two-sided false-alarm rate ~7e-6 per check).
"""

from __future__ import annotations

import numpy as np
import pytest

from turbgen.runs.stencil_cache import cached_stencil
from turbgen.synthesis.mann_spacetime import MannSnapshots, hermitian_complete, mann_box
from stencil_reference import discrete_spectra
from turbgen.synthesis.mann_oracle import slab_factor
from turbgen.synthesis.mann_stencil import BoxShape, build_stencil, expand_k2
from turbgen.synthesis.random_streams import complex_normal
from turbgen.theory.lattice import pair_weights
from turbgen.theory.mann_tensor import tensor_factor
from turbgen.theory.params import MannParams

Z_MAX = 4.5
PARAMS = MannParams(ae=0.3, length_scale_m=49.0, gamma=3.1, evo_time_s=400.0)


def _spectrum(field):
    """u_hat on the synthesis grid from an uncropped (pad 1) field (nt, ny, nz): rfft in t, fft in y, z."""
    f = np.fft.rfft(field.astype(float), axis=0, norm="forward")
    return np.fft.fft2(f, axes=(1, 2), norm="forward")


def _mode_power(stencil):
    """s[c, slab, j, l] = E|u_hat_c|^2 per mode (after Hermitian completion of the k1 = 0 / Nyquist slabs)."""
    box = stencil.box
    s = np.empty((3, box.nk1, box.nyp, box.nzp))
    for i in range(box.nk1):
        c = slab_factor(stencil, i)
        s[:, i] = 2.0 * np.einsum("ikyz,ikyz->iyz", c, c)
        if i == 0 or 2 * i == box.nt:
            s[:, i] = 0.5 * (s[:, i] + np.roll(s[:, i, ::-1, ::-1], 1, axis=(1, 2)))
    return s


@pytest.fixture(scope="module")
def small():
    box = BoxShape(nt=16, dx_m=8.0, nyp=8, nzp=8, dy_m=6.0, dz_m=6.0)
    return build_stencil(PARAMS, box)


def test_compact_factor_rebuilds_tensor_factor(small):
    box = small.box
    scale = np.sqrt(np.prod(box.dk()) / 2.0)
    cells = {tuple(ix) for ix in small.cell_index.tolist()}
    for i in range(box.nk1):
        ref = tensor_factor(box.k1()[i], box.k2()[:, None], box.k3()[None, :], PARAMS) * scale
        got = slab_factor(small, i)
        mask = np.ones((box.nyp, box.nzp), bool)
        for _, j, l in (c for c in cells if c[0] == i):
            mask[j, l] = False
        # float32 storage of the compact numbers: 1e-6 relative to the slab's largest entry
        assert np.abs(got - ref)[:, :, mask].max() <= 1e-6 * np.abs(ref).max()


def test_cell_factors_square_to_cell_average_and_keep_mean_zero(small):
    f = small.cell_factor.astype(float)
    phi = np.einsum("cij,ckj->cik", f, f)
    assert np.all(np.linalg.eigvalsh(phi) >= -1e-12 * np.abs(phi).max())
    origin = np.flatnonzero((small.cell_index == 0).all(axis=1))
    assert origin.size == 1 and np.all(f[origin] == 0.0)


def test_expand_k2_parity():
    half = np.arange(2 * 3 * 4, dtype=float).reshape(2, 3, 4)  # nyp = 4: rows k2 = 0, 1, 2 (Nyquist)
    out = np.empty((2, 4, 4))
    expand_k2(half, 4, True, out)
    assert np.array_equal(out[:, :3], half) and np.array_equal(out[:, 3], -half[:, 1])
    expand_k2(half[:, :3], 5, False, out := np.empty((2, 5, 4)))  # odd nyp: rows 0, 1, 2, -2, -1
    assert np.array_equal(out[:, 3], half[:, 2]) and np.array_equal(out[:, 4], half[:, 1])


def test_noise_streams_are_keyed_and_standard():
    a = complex_normal(5, 2, 7, np.empty((3, 64, 64), np.complex64))
    b = complex_normal(5, 2, 7, np.empty((3 * 64 * 64,), np.complex64))
    assert np.array_equal(a.ravel(), b)  # same key -> same numbers, whatever the shape
    assert not np.array_equal(a, complex_normal(5, 2, 8, np.empty_like(a)))
    x = np.concatenate([a.real.ravel(), a.imag.ravel()]).astype(float)
    n = x.size  # N(0, 1): mean sd 1/sqrt(n), variance sd sqrt(2/n), 4th moment 3 with sd sqrt(96/n)
    assert abs(x.mean()) < Z_MAX / np.sqrt(n)
    assert abs(x.var() - 1.0) < Z_MAX * np.sqrt(2.0 / n)
    assert abs((x**4).mean() - 3.0) < Z_MAX * np.sqrt(96.0 / n)
    assert abs(np.mean(a.real * a.imag)) < Z_MAX / np.sqrt(a.size)


def test_hermitian_completion_of_a_slab():
    rng = np.random.default_rng(0)
    slab = (rng.standard_normal((3, 6, 5)) + 1j * rng.standard_normal((3, 6, 5))).astype(np.complex64)
    hermitian_complete(slab)
    mirror = np.roll(slab[:, ::-1, ::-1], 1, axis=(1, 2))
    np.testing.assert_allclose(slab, np.conj(mirror), rtol=0, atol=1e-6)
    # the 2-D inverse transform of a Hermitian slab is real: the real FFT along k1 keeps all its energy
    assert np.abs(np.fft.ifft2(slab).imag).max() < 1e-6


def test_per_slab_energy_matches_the_discrete_oracle(small):
    """E sum_{k2,k3} |u_hat|^2 per k1 slab, incl. the k1 = 0 and Nyquist slabs (the mannrs trap)."""
    box = small.box
    s = _mode_power(small)
    n_seeds = 300
    acc = np.zeros((3, box.nk1))
    acc_uw = np.zeros(box.nk1)
    for seed in range(n_seeds):
        uh = _spectrum(mann_box(small, box.nyp, box.nzp, seed).transpose(1, 2, 3, 0))
        acc += (np.abs(uh) ** 2).sum(axis=(1, 2)).T
        acc_uw += np.real(uh[..., 0] * np.conj(uh[..., 2])).sum(axis=(1, 2))
    mean = acc / n_seeds
    expect = s.sum(axis=(2, 3))
    oracle = discrete_spectra(small)
    np.testing.assert_allclose(expect, np.einsum("iis->is", oracle), rtol=1e-10)
    # uw co-spectrum per slab: Var Re(u w*) <= s_u s_w per mode (x2 on the Hermitian slabs)
    var_uw = (s[0] * s[2]).sum(axis=(1, 2))
    var_uw[[0, box.nk1 - 1]] *= 2.0
    z_uw = (acc_uw / n_seeds - oracle[0, 2]) / np.sqrt(var_uw / n_seeds)
    assert np.abs(z_uw).max() < Z_MAX, z_uw
    assert np.all(oracle[0, 2, 1:] < 0) and np.all(acc_uw[1:4] < 0)  # shear: negative uw at low k1
    # Var of the slab sum: sum_k s_k^2 over independent modes; on the Hermitian slabs the pair
    # (k, -k) is one complex number counted twice, Var = 2 sum_k s_k^2.
    var = (s**2).sum(axis=(2, 3))
    var[:, [0, box.nk1 - 1]] *= 2.0
    z = (mean - expect) / np.sqrt(var / n_seeds)
    assert np.abs(z).max() < Z_MAX, z
    # the trap: without Hermitian completion the k1 = 0 / Nyquist slabs keep ~half their energy
    for i in (0, box.nk1 - 1):
        assert np.all(mean[:, i] > 0.8 * expect[:, i])


def test_point_variance_and_uw_covariance_match_oracle(small):
    box = small.box
    total = np.einsum("ijs,s->ij", discrete_spectra(small), pair_weights(box.nt))
    n_seeds = 300
    fields = np.stack([mann_box(small, box.nyp, box.nzp, seed) for seed in range(n_seeds)]).astype(float)
    cov = np.einsum("sitab,sjtab->ij", fields, fields) / (n_seeds * box.nt * box.nyp * box.nzp)
    # Box-mean of u_i u_j = sum over the full spectrum of Re(u_hat_i u_hat_j^*) (Parseval) = sum over stored
    # modes of w Re(.) with w = 2 (1 on the Hermitian slabs, whose modes come in pairs counted twice).
    # Var Re(a b*) <= s_a s_b per mode, so Var <= sum over stored modes of 4 s_i s_j in every case.
    s = _mode_power(small)
    for i, j in ((0, 0), (1, 1), (2, 2), (0, 2)):
        sd = np.sqrt(4.0 * (s[i] * s[j]).sum() / n_seeds)
        assert abs(cov[i, j] - total[i, j]) < Z_MAX * sd, (i, j, cov[i, j], total[i, j], sd)
    assert total[0, 2] < 0  # the shear gives negative uw


def test_evolution_cross_spectrum_is_theta(small):
    """Between snapshots dt apart, E[u_hat(t) u_hat^*(t+dt)] = exp(-dt/tau_e) E|u_hat|^2 (Guo et al. 2023, Eq. 13)."""
    box = small.box
    s = _mode_power(small)
    dt = 1.0  # [s]; tau_e on this grid runs from ~0.3 s to ~1000 s, so rho spans (0, 1)
    rho = np.exp(-dt * np.stack([expand_k2(small.inv_tau[i], box.nyp, False, np.empty((box.nyp, box.nzp)))
                                 for i in range(box.nk1)]).astype(float))  # fmt: skip
    assert np.mean((rho > 0.1) & (rho < 0.9)) > 0.2
    gen = MannSnapshots(small, box.nyp, box.nzp, threads=1)
    n_seeds = 300
    acc = np.zeros((3, box.nk1))
    for seed in range(n_seeds):
        planes = {}
        for ix, comp, field in gen.generate(seed, [0.0, dt]):
            planes[(ix, comp)] = _spectrum(field)
        for c, comp in enumerate("uvw"):
            acc[c] += np.real(planes[(0, comp)] * np.conj(planes[(1, comp)])).sum(axis=(1, 2))
    mean = acc / n_seeds
    expect = (rho[None] * s).sum(axis=(2, 3))
    # Var Re(a b*) <= (s^2 + rho^2 s^2)/2 per mode (x2 for the Hermitian pairs)
    var = ((s**2) * (1 + rho[None] ** 2) / 2).sum(axis=(2, 3))
    var[:, [0, box.nk1 - 1]] *= 2.0
    z = (mean - expect) / np.sqrt(var / n_seeds)
    assert np.abs(z).max() < Z_MAX, z
    # decorrelation is visible: the coherent part is clearly below the energy at high k1
    assert np.all(expect[:, -2] < 0.9 * s.sum(axis=(2, 3))[:, -2])
    assert np.all(mean[:, -2] < 0.9 * s.sum(axis=(2, 3))[:, -2])


def test_field_is_identical_for_any_thread_count(small):
    box = small.box
    a = mann_box(small, 5, 6, seed=11, threads=1)
    b = mann_box(small, 5, 6, seed=11, threads=2)
    c = mann_box(small, 5, 6, seed=11, threads=3)
    assert np.array_equal(a, b) and np.array_equal(a, c)
    assert not np.array_equal(a, mann_box(small, 5, 6, seed=12, threads=2))
    gen1 = MannSnapshots(small, box.nyp, box.nzp, threads=1)
    gen2 = MannSnapshots(small, box.nyp, box.nzp, threads=2)
    one = [f.copy() for _, _, f in gen1.generate(3, [0.0, 7.0, 3.0])]
    two = [f.copy() for _, _, f in gen2.generate(3, [0.0, 7.0, 3.0])]
    assert all(np.array_equal(x, y) for x, y in zip(one, two))


def test_snapshot_order_and_frozen_planes(small):
    gen = MannSnapshots(small, 4, 4, threads=1)
    order = [(ix, comp) for ix, comp, _ in gen.generate(0, [3.0, 0.0, 1.0])]
    assert order == [(1, c) for c in "uvw"] + [(2, c) for c in "uvw"] + [(0, c) for c in "uvw"]
    frozen = build_stencil(MannParams(ae=0.3, length_scale_m=49.0, gamma=3.1, evo_time_s=None), small.box)
    assert frozen.inv_tau is None
    out = {}
    for ix, comp, field in MannSnapshots(frozen, 4, 4, threads=1).generate(0, [0.0, 50.0]):
        out[(ix, comp)] = field.copy()
    assert all(np.array_equal(out[(0, c)], out[(1, c)]) for c in "uvw")


def test_zero_mean_of_the_uncropped_box(small):
    box = small.box
    f = mann_box(small, box.nyp, box.nzp, seed=4).astype(float)
    # the k = 0 coefficient is zero: the box mean is zero up to float32 rounding of the FFT
    assert np.abs(f.mean(axis=(1, 2, 3))).max() < 1e-6 * f.std()


def test_stencil_cache_roundtrip(tmp_path, small):
    a = cached_stencil(PARAMS, small.box, tmp_path)
    b = cached_stencil(PARAMS, small.box, tmp_path)
    assert len(list(tmp_path.iterdir())) == 1
    for x in (a, b):
        assert np.array_equal(x.coef, small.coef) and np.array_equal(x.inv_tau, small.inv_tau)
        assert np.array_equal(x.cell_factor, small.cell_factor)


def test_noise_stream_checksum_is_pinned():
    """The random streams are a documented contract (other tools may reproduce a field from them): their
    algorithm (numpy's float32 Ziggurat of the keyed SFC64 stream, compiled, since 2026-11-23 evening; it
    replaced a float32 Box-Muller) is unchanged since, so their bits are pinned here."""
    import hashlib

    h = hashlib.sha256()
    for shape in [(4, 3, 128, 128), (3, 65, 128), (7,), (3, 5, 6), (20000,)]:
        h.update(complex_normal(1, 2, 3, np.empty(shape, np.complex64)).tobytes())
    assert h.hexdigest() == "7c62e72ab3336d5f50a09b22418fc8ef3434b3fed0ca43f08fc6466a4f7629a9"


def test_addend_is_added_before_the_time_transform(small):
    """generate's addend: the sample plus the unnormalised real inverse FFT along k1 of the added spectra (to float32
    round-off), plane by plane; ``seed=None`` gives the addend's field alone; the sample itself is unchanged."""
    box = small.box
    ny, nz, times = 5, 6, [0.0, 7.0, 3.0]
    rng = np.random.default_rng(5)
    add = {(ix, c): (rng.normal(size=(box.nk1, ny * nz)) + 1j * rng.normal(size=(box.nk1, ny * nz))).astype(np.complex64)
           for ix in range(3) for c in range(3)}  # fmt: skip
    gen = MannSnapshots(small, ny, nz, threads=2)
    plain = {(ix, comp): f.copy() for ix, comp, f in gen.generate(3, times)}
    summed = {(ix, comp): f.copy() for ix, comp, f in gen.generate(3, times, lambda ix, c: add[(ix, c)])}
    alone = {(ix, comp): f.copy() for ix, comp, f in gen.generate(None, times, lambda ix, c: add[(ix, c)])}
    for (ix, comp), base in plain.items():
        a = add[(ix, "uvw".index(comp))].astype(complex).reshape(box.nk1, ny, nz)
        expect = np.fft.irfft(a, n=box.nt, axis=0) * box.nt
        scale = np.abs(expect).max()
        assert np.abs(alone[(ix, comp)] - expect).max() < 1e-5 * scale
        assert np.abs(summed[(ix, comp)] - base - expect).max() < 1e-5 * (scale + np.abs(base).max())
    again = {(ix, comp): f.copy() for ix, comp, f in gen.generate(3, times)}  # the addend left nothing behind
    assert all(np.array_equal(plain[k], again[k]) for k in plain)
    with pytest.raises(ValueError, match="shape"):
        next(gen.generate(3, times, lambda ix, c: add[(ix, c)][:-1]))


def test_target_receives_the_same_field(small):
    """generate's target: the planes transformed straight into the caller's whole field hold the same bits as the
    yielded buffers; a target that is not a view of (nt, ny, nz) float32 planes is refused."""
    box = small.box
    ny, nz, times = 5, 6, [0.0, 7.0, 3.0]
    gen = MannSnapshots(small, ny, nz, threads=2)
    plain = {(ix, comp): f.copy() for ix, comp, f in gen.generate(3, times)}
    whole = np.full((3, box.nt, len(times), ny, nz), np.nan, np.float32)  # the store layout (t, x, y, z)
    for ix, comp, f in gen.generate(3, times, target=lambda ix, c: whole[c, :, ix]):
        assert np.shares_memory(f, whole)
    assert all(np.array_equal(whole["uvw".index(comp), :, ix], f) for (ix, comp), f in plain.items())
    with pytest.raises(ValueError, match="target"):
        next(gen.generate(3, times, target=lambda ix, c: whole[c, :, ix, :, ::-1]))  # z reversed: no flat view
