"""Kaimal 4D fields: per-frequency yz synthesis with direct-product longitudinal coherence (evoTurb style).

Cross-spectrum (Guo et al. 2023, Eq. 19): S_c(f) coh_yz(r_ab, f) gamma_x(|x_p - x_q|, f), zero phase between
planes. Per bin k (f_k = k df exactly, not evoTurb's (k + 1) df): yz coefficients by circulant embedding (u: IEC
exponential, Eq. 12 un-squared; v, w white or u's), planes mixed by the square root of gamma_x, amplitudes the
Kaimal PSD (Eq. 11) integrated over the bin, inverse real FFT. Random streams keyed by (seed, component, plane,
FREQ_CHUNK chunk): the field does not depend on how it is written or on threads."""

from __future__ import annotations

import copy
import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from functools import partial

import numpy as np

from turbgen import fft
from turbgen.grid import Grid
from turbgen.synthesis.circulant import Embedding, check_sampling_cost, dense_sampled, embed_many
from turbgen.synthesis.random_streams import keyed_complex_normal
from turbgen.synthesis.square_root import principal_sqrt
from turbgen.theory.coherence_models import exponential_yz, exponential_yz_decay_length_m
from turbgen.theory.kaimal import kaimal_band_variance
from turbgen.theory.lattice import line_bands, line_frequencies
from turbgen.theory.params import KaimalParams

COMPONENTS = ("u", "v", "w")
# frequency bins per random stream; part of the definition of the field for a given seed -- never change
FREQ_CHUNK = 32


def bin_frequencies(nt: int, dt_s: float) -> np.ndarray:
    """f_k = k df [Hz], k = 0 .. nt // 2, df = 1 / (nt dt): the rfft bins, bin k at exactly k df."""
    return line_frequencies(nt, dt_s)


def bin_variances(nt: int, dt_s: float, sigma_m_s: float, length_scale_m: float, U_m_s: float) -> np.ndarray:
    """v_k = integral of the Kaimal PSD (Eq. 11) over [(k - 1/2) df, (k + 1/2) df] clipped at 1/(2 dt) [m^2 s^-2];
    v_0 = 0 (zero mean)."""
    v = kaimal_band_variance(*line_bands(nt, dt_s), sigma_m_s, length_scale_m, U_m_s)
    v[0] = 0.0
    return v


def resolved_band_hz(nt: int, dt_s: float) -> tuple[float, float]:
    """(df/2, 1/(2 dt)) [Hz]: the band whose Kaimal variance the synthesis reproduces."""
    return 0.5 / (nt * dt_s), 0.5 / dt_s


def longitudinal_factors(long_coherence: Callable, x_m, f_hz) -> tuple[np.ndarray, float]:
    """Real principal square roots F_k (nf, P, P) of G_k[p, q] = gamma_x(|x_p - x_q|, f_k), and the spectral norm of the
    negative part clipped."""
    x = np.asarray(x_m, dtype=float)
    f = np.asarray(f_hz, dtype=float)
    dx = np.abs(x[:, None] - x[None, :])
    g = np.asarray(long_coherence(dx[None, :, :], f[:, None, None]), dtype=float)
    g = np.broadcast_to(g, (f.size, x.size, x.size))
    return principal_sqrt(g)


def inverse_transform(spec: np.ndarray, amp: np.ndarray, nt: int, workers: int = 1,
                      out: np.ndarray | None = None, transforms=None) -> np.ndarray:  # fmt: skip
    """One plane's fluctuations (nt, ny, nz) float32 [m/s]: irfft(spec * amp, n=nt, axis=0, norm="forward"), on
    contiguous column blocks (columns are independent: the blocking changes no bit)."""
    nf = spec.shape[0]
    flat = spec.reshape(nf, -1)
    out = np.empty((nt, flat.shape[1]), dtype=np.float32) if out is None else out.reshape(nt, flat.shape[1])
    step = max(16, (1 << 20) // (8 * nf))
    column_amp = amp[:, None]
    transforms = transforms or fft.oneshot()
    for j in range(0, flat.shape[1], step):
        block = flat[:, j:j + step] * column_amp
        out[:, j:j + step] = transforms.irfft(block, n=nt, axis=0, norm="forward", overwrite_x=True, workers=workers)
    return out.reshape(nt, *spec.shape[1:])


class InMemorySpectrum:
    """Spectrum buffer (n_planes, nf, ny, nz) complex64 in memory, serving the components in turn (bin 0 stays 0)."""

    def __init__(self, nx: int, nf: int, ny: int, nz: int):
        self.data = np.zeros((nx, nf, ny, nz), dtype=np.complex64)

    @staticmethod
    def bytes_needed(nx: int, nf: int, ny: int, nz: int) -> int:
        """Bytes [B] of the buffer of this shape (its :attr:`nbytes`)."""
        return nx * nf * ny * nz * np.dtype(np.complex64).itemsize

    @property
    def nbytes(self) -> int:
        return self.data.nbytes

    def chunk(self, k0: int, k1: int) -> np.ndarray:
        """Where bins k0 .. k1 - 1 of all planes are made (nx, k1 - k0, ny, nz): a view of the buffer."""
        return self.data[:, k0:k1]

    def put_chunk(self, k0: int, block: np.ndarray) -> None:
        """Store ``block`` (nx, nb, ny, nz) as bins k0 .. k0 + nb (nothing to do for the view of :meth:`chunk`)."""
        if not np.may_share_memory(block, self.data):
            self.data[:, k0:k0 + block.shape[1]] = block

    def get(self, plane: int) -> np.ndarray:
        """All bins of ``plane`` (nf, ny, nz): a view the caller may modify."""
        return self.data[plane]


class PlaneRing:
    """``size`` (>= 4) reused field planes for :meth:`KaimalEvo.component_planes` (no page faults on fresh planes); a
    consumer must be done with plane k once it asks for plane k + size - 2 (the generator works two planes ahead)."""

    def __init__(self, nt: int, ny: int, nz: int, size: int = 4):
        if size < 4:
            raise ValueError(f"a plane ring needs at least 4 planes, not {size}")
        self.shape = (nt, ny, nz)
        self.size = size
        self._planes: list[np.ndarray] = []
        self._count = 0

    @staticmethod
    def bytes_needed(nt: int, ny: int, nz: int, size: int) -> int:
        """Bytes [B] of a ring of ``size`` planes (its :attr:`nbytes` once every plane is in use)."""
        return size * nt * ny * nz * np.dtype(np.float32).itemsize

    @property
    def nbytes(self) -> int:
        return sum(p.nbytes for p in self._planes)

    def touch(self) -> None:
        """Allocate every plane now and write it once (the first touch of fresh memory, in the caller's thread)."""
        while len(self._planes) < self.size:
            self._planes.append(np.empty(self.shape, dtype=np.float32))
        for plane in self._planes:
            plane.fill(0.0)

    def take(self) -> np.ndarray:
        """The next buffer in turn (allocated on first use)."""
        slot = self._count % self.size
        self._count += 1
        if slot == len(self._planes):
            self._planes.append(np.empty(self.shape, dtype=np.float32))
        return self._planes[slot]


class KaimalEvo:
    """Generator of one Kaimal 4D field, one component at a time, plane by plane; ``long_coherence`` / ``yz_coherence``
    (distance [m], f [Hz]) return un-squared coherences (yz None: IEC exponential_yz); ``yz_decay_length_m(f_hz)``
    bounds yz_coherence <= exp(-r / length) for a smaller torus; ``coherent_vw``: v, w get u's yz coherence (IEC:
    white); ``rescale``: expected variance = nominal sigma^2; ``variances`` (3, nt//2 + 1) band variances [m^2 s^-2] of
    a user spectrum; ``keep``: keep the samplers for :meth:`reseeded` copies."""

    def __init__(
        self,
        kaimal: KaimalParams,
        grid: Grid,
        U_m_s: float,
        seed: int,
        *,
        long_coherence: Callable,
        yz_coherence: Callable | None = None,
        yz_decay_length_m: Callable | None = None,
        long_components: str = "u",
        coherent_vw: bool = False,
        rescale: bool = False,
        variances=None,
        workers: int | None = None,
        fft_backend: str | None = None,
        keep: bool = False,
    ):
        self.kaimal, self.grid, self.U_m_s, self.seed = kaimal, grid, U_m_s, seed
        self.long_coherence = long_coherence
        if yz_coherence is None:
            yz_coherence = partial(exponential_yz, U_m_s=U_m_s, a_yz=kaimal.a_yz, lc_m=kaimal.lc_m)
            if yz_decay_length_m is None:
                yz_decay_length_m = partial(exponential_yz_decay_length_m, U_m_s=U_m_s, a_yz=kaimal.a_yz,
                                            lc_m=kaimal.lc_m)  # fmt: skip
        self.yz_coherence = yz_coherence
        self.yz_decay_length_m = yz_decay_length_m or (lambda f_hz: np.inf)
        self.long_components = long_components
        self.coherent_vw = coherent_vw
        self.workers = workers or os.cpu_count()
        self.transforms = fft.oneshot(fft_backend)  # resolved once: every plane of the run with the same backend
        self._kept: dict | None = {} if keep else None
        self.freqs = bin_frequencies(grid.nt, grid.dt_s)
        self.nf = self.freqs.size
        self.n_chunks = -(-self.nf // FREQ_CHUNK)
        self.variances = {}
        self.rescale_factors = {}
        for i, c in enumerate(COMPONENTS):
            if variances is None:
                v = bin_variances(grid.nt, grid.dt_s, kaimal.sigma_m_s[i], kaimal.length_scales_m[i], U_m_s)
            else:
                v = np.asarray(variances[i], dtype=float)
            factor = kaimal.sigma_m_s[i] ** 2 / v.sum() if rescale and v.sum() > 0 else 1.0
            self.variances[c] = v * factor
            self.rescale_factors[c] = factor
        self.report = {"yz_clip_error": 0.0, "torus_enlarged": 0, "dense_factor_bins": 0, "max_torus": [1, 1],
                       "long_clip_error": 0.0}
        # before anything is allocated: a coherence high far beyond the grid needs huge tori or dense factors
        what = f"the yz coherence (a_yz = {kaimal.a_yz:g}, Lc = {kaimal.lc_m:g} m at U = {U_m_s:g} m/s)"
        decays = [self.yz_decay_length_m(f) for f in self.freqs[1:]]
        self._torus_points = check_sampling_cost(grid.ny, grid.nz, grid.dy_m, grid.dz_m, decays, what)

    def reseeded(self, seed: int) -> "KaimalEvo":
        """This generator for ``seed``: its kept samplers, factors and report shared, only the random streams new."""
        out = copy.copy(self)
        out.seed = seed
        return out

    def _once(self, key, make):
        """``make()``, or with ``keep`` its value kept under ``key`` (made once; the report counts it once)."""
        if self._kept is None:
            return make()
        if key not in self._kept:
            self._kept[key] = make()
        return self._kept[key]

    def sampler_bytes(self) -> int:
        """Peak bytes of the yz samplers while one frequency chunk is made: its bins' embeddings and float32
        copies, the next chunk's made meanwhile, and each thread's complex64 noise over the chunk's tori."""
        g, n = self.grid, self.grid.ny * self.grid.nz
        per_bin = [(8 * n * n, n) if dense_sampled(g.ny, g.nz, points) else (12 * points, points)
                   for points in self._torus_points]
        # per_bin[i] is bin i + 1 (bin 0 is never sampled); chunk c holds bins max(1, c F) .. (c + 1) F - 1
        chunks = [per_bin[max(0, c * FREQ_CHUNK - 1):(c + 1) * FREQ_CHUNK - 1] for c in range(self.n_chunks)]
        held = [sum(b for b, _ in chunk) for chunk in chunks] + [0]
        # a chunk's samplers and noise, and the next chunk's samplers made meanwhile (component_planes)
        noise = [8 * self.workers * sum(p for _, p in chunk) for chunk in chunks]
        return max(held[i] + held[i + 1] + noise[i] for i in range(len(chunks)))

    def expected_variance(self, component: str) -> float:
        """Expected variance [m^2 s^-2] of the synthesised component at every point."""
        return float(self.variances[component].sum())

    def _embeddings(self, component: str, ks: range) -> list[Embedding | None]:
        """yz samplers for bins ks (None = spatially white)."""
        if component != "u" and not self.coherent_vw:
            return [None] * len(ks)
        g = self.grid
        freqs = [self.freqs[k] for k in ks]
        kernels = [lambda r, f=f: self.yz_coherence(r, f) for f in freqs]
        out = embed_many(kernels, g.ny, g.nz, g.dy_m, g.dz_m, [self.yz_decay_length_m(f) for f in freqs])
        rep = self.report
        for e in out:
            rep["yz_clip_error"] = max(rep["yz_clip_error"], e.clip_error)
            rep["torus_enlarged"] += e.enlarged > 0
            if e.chol is not None:
                rep["dense_factor_bins"] += 1
            else:
                rep["max_torus"] = [max(a, b) for a, b in zip(rep["max_torus"], e.torus_shape)]
        return out

    def _groups(self, embs) -> list[tuple[int, int, tuple[int, int], object]]:
        """Runs [i, j) of consecutive bins sampled together: (i, j, torus shape, sampler); sampler None (white), a
        dense-factor Embedding (one bin), or one circulant Embedding stacking the bins' float32 scales."""
        g = self.grid
        shapes = [(g.ny, g.nz) if e is None else e.torus_shape for e in embs]
        kinds = ["white" if e is None else "chol" if e.chol is not None else "circ" for e in embs]
        out = []
        i = 0
        while i < len(embs):
            j = i + 1
            while kinds[i] != "chol" and j < len(embs) and (kinds[j], shapes[j]) == (kinds[i], shapes[i]):
                j += 1
            if kinds[i] == "circ":
                scale = np.empty((j - i, *shapes[i]), dtype=np.float32)
                for b, e in enumerate(embs[i:j]):
                    scale[b] = e.scale  # rounded to float32 as it is stored
                sampler = Embedding(g.ny, g.nz, scale, None, 0.0, 0)
            else:
                sampler = embs[i]
            out.append((i, j, shapes[i], sampler))
            i = j
        return out

    def _chunk_coefficients(self, component: str, plane: int, chunk: int, groups, out: np.ndarray,
                            work: Callable[[int], np.ndarray] | None = None) -> None:
        """yz coefficients (E|Z|^2 = 2) of one plane and frequency chunk into ``out`` (n_bins, ny, nz) complex64."""
        key = (self.seed, COMPONENTS.index(component), plane, chunk)
        # real and imaginary parts N(0, 1): E|xi|^2 = 2, compensated by the amplitudes (component_planes)
        if len(groups) == 1 and groups[0][3] is None and out.flags.c_contiguous:
            keyed_complex_normal(key, out)  # all bins white: the noise is the coefficients, in the same order
            return
        n = sum((j - i) * a * b for i, j, (a, b), _ in groups)
        noise = work(n) if work is not None else np.empty(n, dtype=np.complex64)
        keyed_complex_normal(key, noise)
        pos = 0
        for i, j, shape, sampler in groups:
            n = (j - i) * shape[0] * shape[1]
            xi = noise[pos:pos + n].reshape(j - i, *shape)
            pos += n
            if sampler is None:
                out[i:j] = xi
            elif sampler.chol is not None:
                out[i] = sampler.sample(xi[0], 1, transforms=self.transforms)
            else:
                out[i:j] = sampler.sample(xi, 1, overwrite=True, transforms=self.transforms)  # planes run in parallel

    def _mix_and_put(self, ks: range, block: np.ndarray, spectrum) -> None:
        """Mix the planes' coefficients of bins ``ks`` (``block`` (nx, nb, ny, nz)) with the longitudinal
        coherence's factors and put them into ``spectrum``."""
        g, nx = self.grid, self.grid.nx

        def factors():
            fac, err = longitudinal_factors(self.long_coherence, g.x_m, self.freqs[ks.start:ks.stop])
            self.report["long_clip_error"] = max(self.report["long_clip_error"], err)
            return fac.astype(np.float32)

        flat = block.reshape(nx, len(ks), -1).transpose(1, 0, 2)
        # real factor: mixes real and imaginary parts alike (zero phase between planes)
        mixed_block = self._once(("x", ks.start), factors) @ np.ascontiguousarray(flat).view(np.float32)
        spectrum.put_chunk(ks.start, mixed_block.view(np.complex64).transpose(1, 0, 2).reshape(nx, len(ks), g.ny, g.nz))

    def component_planes(
        self, component: str, tick: Callable[[], None] | None = None, spectrum=None, ring: PlaneRing | None = None
    ) -> Iterator[tuple[int, np.ndarray]]:
        """Yield (plane index, field (nt, ny, nz) float32) for every plane of one component; ``tick`` is called once per
        frequency chunk and per plane; ``ring`` (:class:`PlaneRing`) supplies the arrays."""
        g = self.grid
        spectrum = InMemorySpectrum(g.nx, self.nf, g.ny, g.nz) if spectrum is None else spectrum
        pool = ThreadPoolExecutor(max_workers=self.workers)
        try:  # the pool is shut down however the generator ends (exception, early close)
            self._fill_spectrum(component, pool, spectrum, tick)
            yield from self._transformed(component, pool, spectrum, ring, tick)
        finally:
            pool.shutdown(wait=True, cancel_futures=True)

    def _fill_spectrum(self, component: str, pool: ThreadPoolExecutor, spectrum, tick) -> None:
        """Sample every plane's Fourier coefficients of ``component`` into ``spectrum``, frequency chunk by chunk
        (mixed along x where the component is longitudinally coherent)."""
        nx = self.grid.nx
        mixed = component in self.long_components
        # one work array per pool thread for the torus noise, reused from chunk to chunk and sampled in place
        local = threading.local()

        def work(n):
            if getattr(local, "noise", None) is None or local.noise.size < n:
                local.noise = np.empty(n, dtype=np.complex64)
            return local.noise[:n]

        mixing = []

        def bins(chunk: int) -> range:
            return range(max(1, chunk * FREQ_CHUNK), min(self.nf, (chunk + 1) * FREQ_CHUNK))

        def samplers(chunk: int):  # one pool thread, while the other threads fill the previous chunk's planes
            return self._once((component, chunk), lambda: self._groups(self._embeddings(component, bins(chunk))))

        upcoming = pool.submit(samplers, 0)
        for chunk in range(self.n_chunks):
            ks = bins(chunk)
            groups = upcoming.result()
            if chunk + 1 < self.n_chunks:  # ahead of this chunk's planes in the pool's queue
                upcoming = pool.submit(samplers, chunk + 1)
            if len(ks):
                block = spectrum.chunk(ks.start, ks.stop)

                def fill(p, chunk=chunk, groups=groups, block=block):
                    self._chunk_coefficients(component, p, chunk, groups, block[p], work)

                # planes in parallel, each with its own random stream and block slice: order-independent
                list(pool.map(fill, range(nx)))
                if mixed and nx > 1:  # in the pool, alongside the next chunk's coefficients (disjoint bins)
                    mixing.append(pool.submit(self._mix_and_put, ks, block, spectrum))
                else:
                    spectrum.put_chunk(ks.start, block)
            if tick:
                tick()
        for done in mixing:
            done.result()

    def _transformed(self, component: str, pool: ThreadPoolExecutor, spectrum, ring, tick):
        """Yield (plane index, field) of the filled ``spectrum``: two planes transformed at once (half the threads
        each: the same bits), in order."""
        g = self.grid
        # E|Z|^2 = 2 (real and imaginary parts of unit variance) and 2 E|X_k|^2 = v_k: X_k = sqrt(v_k) / 2 Z_k
        amp = (np.sqrt(self.variances[component]) / 2.0).astype(np.float32)
        if g.nt % 2 == 0:  # the Nyquist coefficient is real: Re(Z) has unit variance, E X^2 = v
            amp[-1] = np.sqrt(self.variances[component][-1]).astype(np.float32)
        fft_workers = max(1, self.workers // 2)

        def transform(p, out):
            spec = spectrum.get(p)
            if g.nt % 2 == 0:
                spec[-1] = spec[-1].real
            return inverse_transform(spec, amp, g.nt, fft_workers, out, self.transforms)

        def submit(p):  # buffers are taken here, in plane order, never in the pool's threads
            return pool.submit(transform, p, None if ring is None else ring.take())

        ahead = [submit(p) for p in range(min(2, g.nx))]
        for p in range(g.nx):
            plane = ahead.pop(0).result()
            if p + 2 < g.nx:
                ahead.append(submit(p + 2))
            if tick:
                tick()
            yield p, plane
