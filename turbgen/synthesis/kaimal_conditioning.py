"""Gaussian conditioning of a Kaimal field on measurement streams, exact for the generator's discrete prior.

As KaimalEvo samples it (Guo et al. 2023, Eq. 19),

    Cov(u_p(n, y), u_q(n', y')) = (1/nt) sum_(k = 1 .. nt - 1) h_k G_k[p, q] R_k(y, y') e^(2 pi i k (n - n') / nt),

G_k = F_k F_k^T, R_k = A_k A_k^H the realised yz correlation, h_k = nt 2 amp_k^2 (nt amp_N^2 at Nyquist).
Diagonal in the bin, so the streams give one dense matrix per frequency, solved as in
turbgen.synthesis.conditioning; C H^T w is one extra synthesis."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from turbgen import fft
from turbgen.synthesis.circulant import Embedding
from turbgen.synthesis.conditioning import Streams
from turbgen.synthesis.kaimal_evo import COMPONENTS, FREQ_CHUNK, KaimalEvo, longitudinal_factors


@dataclass(frozen=True, eq=False)
class BinPrior:
    """The realised prior of one component on frequency bin ``k`` (yz correlation: ``dense`` and ``torus_power``
    None for white noise)."""

    k: int
    weight: float  # h_k [m^2 s^-2] (module docstring)
    long: np.ndarray | None  # G_k (P, P) [-] or None (planes independent)
    dense: np.ndarray | None  # R (N, N) [-] (a dense factor's)
    torus_power: np.ndarray | None  # scale^2 (My, Mz) [-] of a circulant torus

    def at_points(self, iy: np.ndarray, iz: np.ndarray, nz: int) -> np.ndarray:
        """R_k between the grid points (iy, iz) (n,) each: (n, n) float64."""
        if self.dense is not None:
            flat = iy * nz + iz
            return self.dense[np.ix_(flat, flat)]
        if self.torus_power is None:
            return ((iy[:, None] == iy[None, :]) & (iz[:, None] == iz[None, :])).astype(float)
        my, mz = self.torus_power.shape
        lag = fft.oneshot().fft2(self.torus_power).real  # sum_m scale_m^2 e^(-2 pi i m r / M): E[Z(y) Z(y')^*] / 2
        return lag[(iy[:, None] - iy[None, :]) % my, (iz[:, None] - iz[None, :]) % mz]

    def apply(self, f: np.ndarray) -> np.ndarray:
        """R_k f for f (P, ny, nz) complex: the sampler's A A^H (adjoint, then the sampler's own transform)."""
        if self.dense is not None:
            p, ny, nz = f.shape
            return (f.reshape(p, -1) @ self.dense.T).reshape(p, ny, nz)
        if self.torus_power is None:
            return f
        p, ny, nz = f.shape
        my, mz = self.torus_power.shape
        pad = np.zeros((p, my, mz), complex)
        pad[:, :ny, :nz] = f
        g = fft.oneshot().ifft2(pad, norm="forward")  # sum_y f(y) e^(+2 pi i m y / M): the sampler's adjoint
        return fft.oneshot().fft2(self.torus_power * g)[:, :ny, :nz]


def _realised(e: Embedding | None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(dense R, torus scale^2) of a bin's sampler with the float32 values the generator samples with."""
    if e is None:
        return None, None
    if e.chol is not None:
        c = e.chol.astype(np.float32).astype(float)
        return c @ c.T, None
    return None, e.scale.astype(np.float32).astype(float) ** 2


def bin_weights(gen: KaimalEvo, component: str) -> np.ndarray:
    """h_k (nf,) [m^2 s^-2] from the float32 amplitudes KaimalEvo.component_planes applies (bin 0: 0)."""
    nt = gen.grid.nt
    v = gen.variances[component]
    amp = (np.sqrt(v) / 2.0).astype(np.float32).astype(float)
    h = 2.0 * nt * amp**2
    if nt % 2 == 0:  # the real Nyquist coefficient: amplitude sqrt(v_N), E Re(Z)^2 = 1
        h[-1] = nt * float(np.float32(np.sqrt(v[-1]))) ** 2
    return h


def component_prior(gen: KaimalEvo, component: str) -> Iterator[BinPrior]:
    """The realised prior of ``component`` bin by bin (k = 1 .. nt // 2), from the samplers and longitudinal
    factors of ``gen`` (a generator of the run used only for this), chunk by chunk as it makes them."""
    g = gen.grid
    h = bin_weights(gen, component)
    mixed = component in gen.long_components and g.nx > 1
    for chunk in range(gen.n_chunks):
        ks = range(max(1, chunk * FREQ_CHUNK), min(gen.nf, (chunk + 1) * FREQ_CHUNK))
        if not len(ks):
            continue
        embs = gen._embeddings(component, ks)  # the samplers component_planes draws this chunk with
        long = None
        if mixed:
            fac, _ = longitudinal_factors(gen.long_coherence, g.x_m, gen.freqs[ks.start:ks.stop])
            f32 = fac.astype(np.float32).astype(float)
            long = f32 @ f32.transpose(0, 2, 1)
        for b, k in enumerate(ks):
            dense, power = _realised(embs[b])
            yield BinPrior(k, float(h[k]), None if long is None else long[b], dense, power)


@dataclass(frozen=True, eq=False)
class _ComponentTerms:
    """The streams' terms of one component: their stream, shift, weight, and the index of their grid point among
    the distinct points ``iy``, ``iz`` they touch."""

    stream: np.ndarray
    shift: np.ndarray
    weight: np.ndarray
    point: np.ndarray
    iy: np.ndarray
    iz: np.ndarray

    @classmethod
    def of(cls, streams: Streams, c: int, nz: int) -> _ComponentTerms | None:
        sel = np.flatnonzero(streams.term_component == c)
        if sel.size == 0:
            return None
        flat = streams.term_iy[sel] * nz + streams.term_iz[sel]
        uniq, point = np.unique(flat, return_inverse=True)
        return cls(streams.term_stream[sel], streams.term_shift[sel], streams.term_weight[sel], point.ravel(),
                   uniq // nz, uniq % nz)  # fmt: skip

    def transfer(self, k: int, nt: int, m: int) -> np.ndarray:
        """A_kc (M, n_points) complex: sum of w_t e^(2 pi i k s_t / nt) per (stream, point)."""
        a = np.zeros((m, len(self.iy)), complex)
        np.add.at(a, (self.stream, self.point), self.weight * np.exp(2j * np.pi * k * self.shift / nt))
        return a


def _coupling(b: BinPrior, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """G_k[rows, cols], or 1 where the planes are equal for a component whose planes are independent."""
    if b.long is None:
        return (rows[:, None] == cols[None, :]).astype(float)
    return b.long[np.ix_(rows, cols)]


def stream_covariance(gen: KaimalEvo, streams: Streams, noise_var) -> np.ndarray:
    """The per-frequency matrices S_j (nt/q, M, M) complex128 of S = H C H^T + R (the layout of
    conditioning.stream_covariance), from the samplers of ``gen`` (a generator of the run used only for this) and
    the noise variances ``noise_var`` (M,) [m^2 s^-2]."""
    g = gen.grid
    nt, q, m = g.nt, streams.decimation, streams.n_streams
    n_dec = nt // q
    doff = 2j * np.pi * (streams.offset[:, None] - streams.offset[None, :]) / nt
    out = np.zeros((n_dec, m, m), complex)
    for c, comp in enumerate(COMPONENTS):
        terms = _ComponentTerms.of(streams, c, g.nz)
        if terms is None:
            continue
        for b in component_prior(gen, comp):
            a = terms.transfer(b.k, nt, m)
            full = (a @ b.at_points(terms.iy, terms.iz, g.nz) @ a.conj().T) * _coupling(b, streams.plane, streams.plane)
            full *= b.weight
            i = b.k
            out[i % n_dec] += full * np.exp(i * doff) / q
            if 2 * i != nt:  # the mirror frequency nt - i: L_(nt - i) = conj L_i
                out[(nt - i) % n_dec] += full.conj() * np.exp((nt - i) * doff) / q
    out[:, np.arange(m), np.arange(m)] += np.asarray(noise_var, dtype=float)
    return out


@dataclass(frozen=True, eq=False)
class Correction:
    """C H^T w of one component in spectral form: ``spectra`` Y (Q, nf, ny, nz) complex64, the yz-correlated
    spectra of the Q measured planes ``planes``, and ``long`` G_k[p, q] (nf, nx, Q) [-] or None (planes
    independent): plane p's spectrum is X_kp = sum_q G_k[p, q] Y_kq (:meth:`field`)."""

    planes: np.ndarray
    spectra: np.ndarray
    long: np.ndarray | None

    def field(self, plane: int, nt: int) -> np.ndarray:
        """The correction on ``plane``, (nt, ny, nz) float64 [m/s]: the generator's real inverse FFT (norm "forward")"""
        if self.long is None:
            hit = np.flatnonzero(self.planes == plane)
            if hit.size == 0:
                return np.zeros((nt, *self.spectra.shape[2:]))
            spec = self.spectra[hit[0]].astype(complex)
        else:
            spec = np.einsum("kq,qkyz->kyz", self.long[:, plane], self.spectra.astype(complex))
        return fft.oneshot().irfft(spec, n=nt, axis=0, norm="forward")


def correction(gen: KaimalEvo, streams: Streams, weights: np.ndarray, component: str) -> Correction:
    """C H^T w for one component: per bin, the weights through the adjoint of the streams' terms, times R_k h_k / nt."""
    g = gen.grid
    nt, m = g.nt, streams.n_streams
    terms = _ComponentTerms.of(streams, COMPONENTS.index(component), g.nz)
    planes = streams.used_planes()
    mixed = component in gen.long_components and g.nx > 1
    spectra = np.zeros((len(planes), gen.nf, g.ny, g.nz), np.complex64)
    long = np.zeros((gen.nf, g.nx, len(planes))) if mixed else None
    if terms is None:
        return Correction(planes, spectra, long)
    full = np.zeros((m, nt))
    for a in range(m):  # the samples at their stored time steps o_a + m q
        full[a, streams.offset[a] :: streams.decimation] = weights[a]
    spec_w = fft.oneshot().rfft(full, axis=1)
    on_plane = (planes[:, None] == streams.plane[None, :]).astype(float)  # (Q, M)
    flat = terms.iy * g.nz + terms.iz
    for b in component_prior(gen, component):
        a = terms.transfer(b.k, nt, m)
        grid = np.zeros((len(planes), g.ny * g.nz), complex)
        grid[:, flat] = on_plane @ (spec_w[:, b.k, None] * a.conj())  # H^T w on each measured plane
        spectra[:, b.k] = b.apply(grid.reshape(len(planes), g.ny, g.nz)) * (b.weight / nt)
        if mixed:
            long[b.k] = b.long[:, planes]
    return Correction(planes, spectra, long)
