"""Gaussian conditioning of a Mann field on measurement streams, exact for the generator's discrete prior.

Hoffman & Ribak (1991): with the prior u ~ N(0, C) (turbgen.synthesis.prior_spectrum), measurements
d = H u + eps, eps ~ N(0, R) and S = H C H^T + R, a conditional sample is

    u_c = u_s + C H^T S^-1 (d - H u_s - eps_s),      u_s ~ N(0, C), eps_s ~ N(0, R)

(C H^T S^-1 d: the conditional mean). Stream a combines values of one plane p_a, y_a(n) = sum_t w_t
u_(c_t)(n + s_t, y_t, z_t), observed as z_a(m) = y_a(o_a + m q). The stored time axis is periodic, so S is
block-circulant: one Hermitian (streams x streams) matrix per frequency. At full rate, slab i gives

    L_i[a, b] = nt sum_(t in a, t' in b) w_t w_t' G_i^(p_a p_b)[c_t, c_t'](y_t - y_t', z_t - z_t')
                * e^(2 pi i i (s_t - s_t') / nt)

with G_i^(pq)(dy, dz) = sum_(j, l) rho_pq Phi_i exp(2 pi i (j dy / nyp + l dz / nzp)) (real part on the k1 = 0 /
Nyquist slabs), rho_pq = exp(-|t_p - t_q| / tau_e) (Guo et al. 2023, Eq. 13-14), L_(nt - i) = conj L_i, and the
decimated streams alias the q full-rate frequencies onto j:
S_j[a, b] = (1/q) sum_l L_(j + l nt/q)[a, b] e^(2 pi i (j + l nt/q)(o_a - o_b) / nt) + sigma_a^2 delta_ab.
Gaps, the per-direction grouping of terms and C H^T w: docs/constrained-fields.md, "How it is solved"."""

from __future__ import annotations

import queue
from collections import deque
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from turbgen import fft
from turbgen.errors import ParameterError
from turbgen.synthesis import conditioning_kernels as kernels
from turbgen.synthesis.mann_oracle import slab_factor
from turbgen.synthesis.mann_stencil import MannStencil
from turbgen.synthesis.prior_spectrum import slab_inv_tau, slab_weight

CG_TOLERANCE = 1e-10  # relative residual |S x - r| / |r| at which the conjugate gradients stop
CG_MAX_ITERATIONS = 5000  # a bound on the conjugate gradients (the circulant preconditioner knows nothing of the gaps)
# missing fraction above which conjugate gradients start from the precision-matrix solve (_gap_start)
GAP_START_FRACTION = 1 / 16
SINGULAR_RTOL = 1e-11  # eigenvalue / largest eigenvalue of S_i below which zero-noise measurements are dependent


@dataclass(frozen=True, eq=False)
class Streams:
    """Measurement streams on the stored grid: (M,) arrays per stream, (T,) ``term_*`` arrays per term."""

    plane: np.ndarray
    term_stream: np.ndarray
    term_component: np.ndarray  # 0 u, 1 v, 2 w
    term_iy: np.ndarray
    term_iz: np.ndarray
    term_weight: np.ndarray  # [-]
    names: tuple[str, ...]
    term_shift: np.ndarray | None = None  # s_t >= 0 [stored steps]
    decimation: int = 1  # q (divides nt)
    offset: np.ndarray | None = None  # o_a in [0, q) of each stream's first sample

    def __post_init__(self):
        if self.term_shift is None:
            object.__setattr__(self, "term_shift", np.zeros(len(self.term_stream), np.int64))
        if self.offset is None:
            object.__setattr__(self, "offset", np.zeros(len(self.plane), np.int64))

    @property
    def n_streams(self) -> int:
        """M, the number of streams."""
        return len(self.plane)

    def used_planes(self) -> np.ndarray:
        """The plane indices that carry streams, sorted."""
        return np.unique(self.plane)


def measure(streams: Streams, plane: int, component: int, field: np.ndarray, out: np.ndarray) -> None:
    """Add H's terms on (``plane``, ``component``) applied to ``field`` (nt, ny, nz) [m/s] into ``out`` (M, nt/q)."""
    sel = np.flatnonzero((streams.plane[streams.term_stream] == plane) & (streams.term_component == component))
    nt, q = field.shape[0], streams.decimation
    samples = np.arange(nt // q) * q
    for t in sel:
        a = streams.term_stream[t]
        n = (streams.offset[a] + samples + streams.term_shift[t]) % nt
        out[a] += streams.term_weight[t] * field[n, streams.term_iy[t], streams.term_iz[t]]


def measure_spectra(streams: Streams, plane: int, spectra: np.ndarray, nz: int, nt: int, out: np.ndarray,
                    points: np.ndarray | None = None) -> None:  # fmt: skip
    """Add Y_a(i) = sum_t w_t U_(c_t)(i, y_t, z_t) exp(2 pi i i s_t / nt) of H's terms on ``plane`` into ``out``
    (M, nk1), from the cropped spectra of that plane's snapshot (all points, or the sorted ``points`` only)."""
    sel = np.flatnonzero(streams.plane[streams.term_stream] == plane)
    if len(sel) == 0:
        return
    sel = sel[np.argsort(streams.term_stream[sel], kind="stable")]
    nk1 = spectra.shape[-1]
    shift = streams.term_shift[sel]
    phase = np.exp(2j * np.pi * ((np.arange(nk1)[None, :] * np.arange(shift.max() + 1)[:, None]) % nt) / nt)
    point = streams.term_iy[sel] * nz + streams.term_iz[sel]
    values = spectra[streams.term_component[sel], point if points is None else np.searchsorted(points, point)]
    values = values * (streams.term_weight[sel, None] * phase[shift])
    stream = streams.term_stream[sel]
    starts = np.flatnonzero(np.r_[True, stream[1:] != stream[:-1]])
    out[stream[starts]] += np.add.reduceat(values, starts, axis=0)


def measured_points(streams: Streams, nz: int) -> np.ndarray:
    """The sorted cropped points y nz + z the streams' terms read (MannSnapshots' ``points``)."""
    return np.unique(streams.term_iy * nz + streams.term_iz)


def spectra_samples(streams: Streams, spectra: np.ndarray, nt: int) -> np.ndarray:
    """H u (M, nt/q) [m/s] from the streams' time spectra (M, nk1) of :func:`measure_spectra`: their unnormalised
    real inverse FFT (as the generator's transform along time: the imaginary parts at k1 = 0 and Nyquist are
    ignored), sampled at each stream's stored time steps o_a + m q."""
    full = fft.oneshot().irfft(spectra, n=nt, axis=1) * nt
    q = streams.decimation
    index = streams.offset[:, None] + np.arange(nt // q)[None, :] * q
    return np.take_along_axis(full, index, axis=1)


def _slab_components(stencil: MannStencil, i: int, rows: int) -> np.ndarray:
    """Phi_i = 2 C C^T's six components (6, rows nzp) float64 in COMPONENT_PAIRS order on the rows 0 .. rows - 1 of
    slab ``i`` (from mann_oracle.slab_factor's operations: kernels.slab_components)."""
    box = stencil.box
    scratch = None if stencil.coef is not None else np.empty((4, 1, box.nk2_half, box.nzp), np.float32)
    coef, j = stencil.coefficients(i, i + 1, scratch)
    cells = stencil.cells_in(i, i + 1)
    out = np.empty((len(COMPONENT_PAIRS), rows, box.nzp))
    kernels.slab_components(coef, j, float(box.k1()[i]), box.k2(), box.k3() ** 2, stencil.cell_index[cells, 1],
                            stencil.cell_index[cells, 2], stencil.cell_factor[cells].astype(float), out)  # fmt: skip
    return out.reshape(len(COMPONENT_PAIRS), -1)


def _slab_phi(stencil: MannStencil, i: int) -> np.ndarray:
    """Phi_i = 2 C C^T (3, 3, nyp nzp) (C: mann_oracle.slab_factor), symmetrised under k -> -k on the
    k1 = 0 / Nyquist slabs (their real part: see prior_spectrum)."""
    box = stencil.box
    components = _slab_components(stencil, i, box.nyp)
    phi = np.empty((3, 3, components.shape[1]))
    for n, (a, b) in enumerate(COMPONENT_PAIRS):
        phi[a, b] = phi[b, a] = components[n]
    if slab_weight(stencil, i) == 1.0:
        grid = phi.reshape(3, 3, box.nyp, box.nzp)
        phi = (0.5 * (grid + np.roll(grid[..., ::-1, ::-1], 1, axis=(-2, -1)))).reshape(3, 3, -1)
    return phi


LAG_DECIMALS = 9  # plane-time lags |t_p - t_q| equal to 1e-9 s share one lag covariance (evenly spaced gates)
SLAB_GROUP = 8  # slabs transformed in one call
PARALLEL_RTOL = 1e-12  # a stream's terms along one direction: component weights parallel to it to this relative
DIRECTION_DECIMALS = 12


@dataclass(frozen=True, eq=False)
class _Keys:
    """The streams' terms grouped per (stream, direction, y, z) node (a *key*), sorted by stream; ``term_key`` -1 marks
    a term carried by another component of its node."""

    term_key: np.ndarray
    term_weight: np.ndarray
    bounds: np.ndarray
    dir: np.ndarray
    iy: np.ndarray
    iz: np.ndarray
    directions: np.ndarray


def _stream_direction(streams: Streams, sel: np.ndarray) -> np.ndarray | None:
    """The unit vector n with every (y, z, shift) group of the terms ``sel`` having component weights parallel to n
    (a lidar beam's line of sight; a single component's axis), or None."""
    rows = np.stack([streams.term_iy[sel], streams.term_iz[sel], streams.term_shift[sel]], axis=1)
    uniq, inverse = np.unique(rows, axis=0, return_inverse=True)
    vec = np.zeros((len(uniq), 3))
    np.add.at(vec, (inverse.ravel(), streams.term_component[sel]), streams.term_weight[sel])
    norms = np.linalg.norm(vec, axis=1)
    n = vec[int(np.argmax(norms))] / norms.max()
    along = vec @ n
    off = np.linalg.norm(vec - along[:, None] * n[None], axis=1)
    return n if np.all(off <= PARALLEL_RTOL * norms.max()) else None


def _keys(streams: Streams) -> _Keys:
    """Each stream along its own direction where its terms allow (_stream_direction), else per component."""
    directions: list[tuple[float, ...]] = []
    term_dir = np.empty(len(streams.term_stream), np.int64)
    weight = np.zeros(len(streams.term_stream))
    for a in range(streams.n_streams):
        sel = np.flatnonzero(streams.term_stream == a)
        n = _stream_direction(streams, sel)
        # directions equal to DIRECTION_DECIMALS share their lag covariances (the beam of every gate)
        vectors = [tuple(np.round(n, DIRECTION_DECIMALS))] if n is not None else [
            tuple(np.eye(3)[c]) for c in range(3)]
        for v in vectors:
            if v not in directions:
                directions.append(v)
        if n is None:
            term_dir[sel] = [directions.index(vectors[c]) for c in streams.term_component[sel]]
            weight[sel] = streams.term_weight[sel]
        else:  # the terms of the largest component of n carry each node's weight along n
            big = int(np.argmax(np.abs(n)))
            term_dir[sel] = directions.index(vectors[0])
            weight[sel] = np.where(streams.term_component[sel] == big, streams.term_weight[sel] / n[big], 0.0)
    rows = np.stack([streams.term_stream, term_dir, streams.term_iy, streams.term_iz], axis=1)
    uniq, inverse = np.unique(rows, axis=0, return_inverse=True)
    term_key = np.where(weight != 0.0, inverse.ravel(), -1).astype(np.int64)
    bounds = np.searchsorted(uniq[:, 0], np.arange(streams.n_streams + 1)).astype(np.int64)
    return _Keys(term_key, weight, bounds, *(np.ascontiguousarray(uniq[:, n]) for n in (1, 2, 3)),
                 np.array(directions, dtype=float))  # fmt: skip


def _lag_classes(times: np.ndarray, plane: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct plane-time lags |t_p - t_q| [s] of the streams' planes and the class (M, M) of each stream pair."""
    lag = np.round(np.abs(times[plane][:, None] - times[plane][None, :]), LAG_DECIMALS)
    values, cls = np.unique(lag, return_inverse=True)
    return values, cls.reshape(lag.shape).astype(np.int64)


class _GroupFFT:
    """Single-threaded in-place complex64 plans over the last two axes of a slab group's arrays (one per group
    size): the same rounding for any thread count. ``keep_z``: exact on the output columns z < keep_z only; ``rows``
    (first, end): for an input zero outside those rows."""

    def __init__(self, tail: tuple[int, ...], backend: fft.FFTBackend, kind: str = "c2c_forward",
                 keep_z: int | None = None, rows: tuple[int, int] | None = None):  # fmt: skip
        self.tail, self.backend, self.kind, self.keep_z, self.rows = tail, backend, kind, keep_z, rows
        self._plans: dict[int, tuple[np.ndarray, _Plan]] = {}

    def buffers(self, n: int) -> tuple[np.ndarray, _Plan]:
        """(array, plan) for a group of ``n`` slabs."""
        if n not in self._plans:
            inp = self.backend.empty((n, *self.tail), np.complex64)
            kept = inp if self.keep_z is None else inp[..., : self.keep_z]
            nonzero = inp if self.rows is None else inp[..., self.rows[0] : self.rows[1], :]
            plans = [self.backend.plan(self.kind, nonzero, nonzero, -1), self.backend.plan(self.kind, kept, kept, -2)]
            self._plans[n] = (inp, _Plan(plans))
        return self._plans[n]


class _Plan:
    """Plans executed in turn."""

    def __init__(self, plans: list):
        self._plans = plans

    def execute(self) -> None:
        for plan in self._plans:
            plan.execute()


# Phi's components (a, b), the four even in k2 first (Phi_12 and Phi_23 are odd: y -> -y turns v)
COMPONENT_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 2), (0, 1), (1, 2))
N_EVEN = 4


@dataclass(frozen=True, eq=False)
class _Basis:
    """The lag covariances transformed per slab and lag: the direction pairs' own (``is_pairs``) or Phi's six
    components, each pair's then sum_b weights[p, b] of them. ``first``/``second`` (B,) the directions of each
    input, the first ``n_even`` of them even in k2."""

    directions: np.ndarray
    first: np.ndarray
    second: np.ndarray
    weights: np.ndarray
    n_even: int
    is_pairs: bool

    @property
    def n(self) -> int:
        return len(self.first)


def _basis(directions: np.ndarray) -> _Basis:
    """The cheaper basis for these directions: their pairs' own up to six pairs, Phi's components beyond."""
    n_pairs = len(directions) * (len(directions) + 1) // 2
    return _direction_basis(directions) if n_pairs <= len(COMPONENT_PAIRS) else _component_basis(directions)


def _direction_basis(directions: np.ndarray) -> _Basis:
    first, second = np.triu_indices(len(directions))
    return _Basis(directions, first, second, np.eye(len(first)), len(first), True)


def _component_basis(directions: np.ndarray) -> _Basis:
    first, second = np.triu_indices(len(directions))
    a, b = (np.array(v) for v in zip(*COMPONENT_PAIRS))
    n, m = directions[first], directions[second]  # n^T Phi n' = sum_(a <= b) (n_a n'_b + n_b n'_a [a != b]) Phi_ab
    weights = n[:, a] * m[:, b] + np.where(a != b, n[:, b] * m[:, a], 0.0)
    return _Basis(np.eye(3), a, b, weights, N_EVEN, False)


class _LagTransform:
    """The real 2-D DFTs of one slab's lag inputs, exact on the columns z < min(e_z, nzp // 2 + 1); single-threaded
    plans: the same rounding for any thread count. With ``parity`` (nyp even) y is a DCT-I / DST-I."""

    def __init__(self, basis: _Basis, n_pairs: int, nyp: int, nzp: int, extent: tuple[int, int],
                 backend: fft.FFTBackend):  # fmt: skip
        self.basis, self.nzp = basis, nzp
        self.parity = basis.n_even < basis.n and nyp % 2 == 0
        self.rows = nyp // 2 + 1 if self.parity else nyp
        keep_z = min(extent[1], nzp // 2 + 1)
        self.x = backend.empty((basis.n, self.rows, nzp), np.float64)
        self.z = backend.empty((basis.n, self.rows, nzp // 2 + 1), np.complex128)
        self.window = np.empty((basis.n, 2 * extent[0] - 1, 2 * extent[1] - 1), np.complex128)
        self.pairs = self.window if basis.is_pairs else np.empty((n_pairs, *self.window.shape[1:]), np.complex128)
        plans = [backend.plan("r2c", self.x, self.z, -1)]
        kept = self.z[..., :keep_z]
        if not self.parity:
            plans.append(backend.plan("c2c_forward", kept, kept, -2))
        else:
            even = kept[: basis.n_even].view(np.float64)  # (real, imaginary) pairs: the real transform of each
            plans.append(backend.plan("dct1", even, even, -2))
            if nyp > 2:
                odd = kept[basis.n_even :, 1 : nyp // 2].view(np.float64)
                plans.append(backend.plan("dst1", odd, odd, -2))
        self._plans = plans

    def execute(self) -> np.ndarray:
        """Transform ``x``; the direction pairs' lag covariances over the window (``pairs``)."""
        for plan in self._plans:
            plan.execute()
        kernels.lag_window(self.z, self.basis.n_even, self.parity, self.nzp, self.window)
        if not self.basis.is_pairs:
            flat = lambda a: a.reshape(len(a), -1).view(np.float64)  # noqa: E731
            kernels.combine_pairs(flat(self.window), self.basis.weights, flat(self.pairs))
        return self.pairs


def _slab_system(stencil: MannStencil, i: int, lags: np.ndarray, keys: _Keys, basis: _Basis, amp: np.ndarray,
                 dir_pair: np.ndarray, pair_class: np.ndarray, transform: _LagTransform, out: np.ndarray) -> None:
    """L_i (``out`` (M, M), zeroed here) of slab ``i`` from the key amplitudes ``amp`` (K,), one lag class at a time
    (the DFTs stay in cache)."""
    box = stencil.box
    symmetric = slab_weight(stencil, i) == 1.0  # symmetrised under k -> -k, as _slab_phi (1/tau_e is even in k)
    rows = box.nyp if symmetric else transform.rows  # symmetrised on the whole plane, then cut to the rows used
    if basis.is_pairs:  # 2 (C^T n) . (C^T n') = n^T Phi n', C the slab's factor (prior_spectrum)
        factor = slab_factor(stencil, i).reshape(3, 3, box.nyp, box.nzp)[:, :, :rows].reshape(3, 3, -1)
        psi = np.empty((basis.n, rows * box.nzp))
        kernels.direction_products(factor, basis.directions, basis.first, basis.second, psi)
    else:  # Phi's components themselves
        psi = _slab_components(stencil, i, rows)
    inv_tau = slab_inv_tau(stencil, i)
    inv_tau = None if inv_tau is None else inv_tau.reshape(box.nyp, box.nzp)[:rows].reshape(-1)
    x = np.empty((basis.n, rows, box.nzp)) if symmetric else transform.x
    out[...] = 0.0
    for cls, rho in enumerate(_lag_factors(lags, inv_tau, psi.shape[1])):
        kernels.lag_input(psi, rho, x.reshape(basis.n, -1))
        if symmetric:
            transform.x[...] = (0.5 * (x + np.roll(x[..., ::-1, ::-1], 1, axis=(-2, -1))))[:, : transform.rows]
        pairs = transform.execute()
        kernels.pair_sums(amp, keys.bounds, keys.dir, keys.iy, keys.iz, dir_pair, pair_class, cls, pairs, out)


def _lag_factors(lags: np.ndarray, inv_tau: np.ndarray | None, n_points: int) -> Iterator[np.ndarray]:
    """exp(-lag / tau_e) (J,) on a slab's J points for each lag class in turn (ones if ``inv_tau`` is None); evenly
    spaced lags as powers of exp(-d / tau_e), as the generator's Ornstein-Uhlenbeck recursion. Updated in place."""
    if inv_tau is None:
        ones = np.ones(n_points)
        yield from (ones for _ in lags)
        return
    n = np.arange(len(lags))
    even = len(lags) > 2 and lags[0] == 0.0 and np.all(np.abs(lags - n * lags[1]) <= n * 10.0**-LAG_DECIMALS)
    rho, step = np.empty(n_points), np.empty(n_points)
    for cls, lag in enumerate(lags):
        if even and cls >= 2:
            kernels.times_into(rho, step)
        else:
            kernels.lag_factors(lag, inv_tau, rho)
            if cls == 1:
                step[:] = rho
        yield rho


def _direction_pairs(n_dir: int) -> np.ndarray:
    """(D, D) the index of each direction pair among the D (D + 1) / 2 of np.triu_indices (symmetric)."""
    out = np.empty((n_dir, n_dir), np.int64)
    first, second = np.triu_indices(n_dir)
    out[first, second] = out[second, first] = np.arange(len(first))
    return out


def stream_covariance(stencil: MannStencil, streams: Streams, times_s, noise_var, threads: int = 1,
                      progress=None) -> np.ndarray:  # fmt: skip
    """The per-frequency matrices S_j (nt/q, M, M) complex128 [m^2 s^-2 times nt] of the block-circulant S; ``times_s``:
    relative time x/U [s] of every plane; ``noise_var`` (M,): sigma_a^2 [m^2 s^-2] (R = diag)."""
    box = stencil.box
    nt, q, m = box.nt, streams.decimation, streams.n_streams
    n_dec = nt // q
    keys = _keys(streams)
    dir_pair = _direction_pairs(len(keys.directions))
    basis = _basis(keys.directions)
    lags, pair_class = _lag_classes(np.asarray(times_s, dtype=float), streams.plane)
    doff = 2j * np.pi * (streams.offset[:, None] - streams.offset[None, :]) / nt
    n_pairs = len(keys.directions) * (len(keys.directions) + 1) // 2
    extent = (int(np.ptp(keys.iy)) + 1, int(np.ptp(keys.iz)) + 1)  # the pair sums read |y_k - y_k'| < extent[0], ...

    def group(transform: _LagTransform, slabs: range) -> list[np.ndarray]:  # L_i of the group's slabs
        amp = np.empty((len(slabs), len(keys.dir)), complex)
        kernels.key_amplitudes(keys.term_key, streams.term_shift, keys.term_weight, np.array(slabs, np.int64), nt,
                               amp)  # fmt: skip
        fulls = [np.empty((m, m), complex) for _ in slabs]
        for b, i in enumerate(slabs):
            _slab_system(stencil, i, lags, keys, basis, amp[b], dir_pair, pair_class, transform, fulls[b])
        return fulls

    out = np.zeros((n_dec, m, m), complex)
    groups = [range(s0, min(s0 + SLAB_GROUP, box.nk1)) for s0 in range(0, box.nk1, SLAB_GROUP)]
    backend = fft.backend()
    workspace = lambda: _LagTransform(basis, n_pairs, box.nyp, box.nzp, extent, backend)  # noqa: E731
    for slabs, fulls in zip(groups, _ordered_map(group, groups, threads, workspace)):
        for i, full in zip(slabs, fulls):  # summed in slab order: the same bits for any thread count
            full *= nt
            out[i % n_dec] += full * np.exp(i * doff) / q
            if 0 < i and 2 * i != nt:  # the mirror frequency nt - i: L_(nt - i) = conj L_i
                out[(nt - i) % n_dec] += full.conj() * np.exp((nt - i) * doff) / q
        if progress is not None:
            progress(len(slabs))
    out[:, np.arange(m), np.arange(m)] += np.asarray(noise_var, dtype=float)
    return out


def _ordered_map(fn, items: list, threads: int, workspace) -> Iterator:
    """fn(ws, item) for every item, in order; up to ``threads`` items at once, each with a workspace ws of its own
    (``workspace()``), and at most ``threads`` finished results waiting for the consumer."""
    if threads <= 1:
        ws = workspace()
        for item in items:
            yield fn(ws, item)
        return
    spare: queue.SimpleQueue = queue.SimpleQueue()
    for _ in range(threads):
        spare.put(workspace())

    def task(item):
        ws = spare.get()
        try:
            return fn(ws, item)
        finally:
            spare.put(ws)

    with ThreadPoolExecutor(threads) as pool:
        pending: deque = deque()
        for item in items:
            pending.append(pool.submit(task, item))
            if len(pending) > threads:
                yield pending.popleft().result()
        while pending:
            yield pending.popleft().result()


def check_singular(cov: np.ndarray, names) -> None:
    """Raise ParameterError naming the linearly dependent measurements (S_i singular on some slab), decided with margins
    (:func:`dependent_set`) so that every CPU names the same ones."""
    lam = np.linalg.eigvalsh(cov[: cov.shape[0] // 2 + 1])  # all at once
    top = np.maximum(lam[:, -1], np.finfo(float).tiny)
    singular = np.flatnonzero(lam[:, 0] <= SINGULAR_RTOL * top)
    if len(singular):
        i = int(singular[0])
        involved = [names[a] for a in dependent_set(cov[i])]
        raise ParameterError(
            "the measurements " + ", ".join(involved) + " are linearly dependent with zero noise (singular "
            f"system at frequency index {i}): remove one of them or give a noise level > 0 (`--noise`)"
        )


DEPENDENT_RTOL = 1e-8  # residual variance / variance at or below which a measurement is a combination of earlier ones
INVOLVED_RTOL = 1e-5  # share (|c_k| sigma_k / sigma_a) above which an earlier measurement is part of that combination


def dependent_set(s: np.ndarray) -> list[int]:
    """The smallest dependent set of the Hermitian S >= 0 (M, M), increasing (pivoted Cholesky): the first measurement
    whose residual variance is <= DEPENDENT_RTOL of its variance, and the earlier ones its combination uses
    (share > INVOLVED_RTOL): thresholds far from round-off, so the set does not depend on the CPU."""
    m = s.shape[0]
    var = np.real(np.diag(s)).copy()
    low = np.zeros((m, m), complex)  # L of the independent pivots so far: S_II = L L^H
    basis: list[int] = []
    rho = np.ones(m)
    for a in range(m):
        k = len(basis)
        y = np.linalg.solve(low[:k, :k], s[basis, a]) if k else np.zeros(0, complex)  # L^-1 S_Ia
        resid = max(var[a] - float(np.real(np.vdot(y, y))), 0.0)
        rho[a] = resid / var[a] if var[a] > 0 else 0.0
        if rho[a] <= DEPENDENT_RTOL:
            coef = np.linalg.solve(low[:k, :k].conj().T, y) if k else y  # S_II^-1 S_Ia = L^-H L^-1 S_Ia
            share = np.abs(coef) * np.sqrt(var[basis] / var[a]) if var[a] > 0 else np.zeros(k)
            return sorted({*(b for b, w in zip(basis, share) if w > INVOLVED_RTOL), a})
        low[k, :k] = y.conj()
        low[k, k] = np.sqrt(resid)
        basis.append(a)
    a = int(np.flatnonzero(rho <= 10 * rho.min())[0])
    return sorted({*_involved(s, [b for b in basis if b < a], a, var), a})


def _involved(s: np.ndarray, basis: list[int], a: int, var: np.ndarray) -> list[int]:
    """The measurements of ``basis`` that measurement ``a``'s least-squares combination uses (share > INVOLVED_RTOL)."""
    if not basis:
        return []
    c = np.linalg.solve(s[np.ix_(basis, basis)], s[basis, a])
    share = np.abs(c) * np.sqrt(var[basis]) / np.sqrt(max(var[a], np.finfo(float).tiny))
    return [b for b, w in zip(basis, share) if w > INVOLVED_RTOL]


def circulant_apply(cov: np.ndarray, v: np.ndarray) -> np.ndarray:
    """S v for full streams ``v`` (M, nt/q): real FFT over the samples, S_j per frequency j <= nt/(2q) (the streams
    are real: S_(n - j) = conj S_j), inverse real FFT. ``cov`` may be other per-frequency matrices with the same
    symmetry, e.g. the inverses of S_j (only its first nt/(2q) + 1 are read)."""
    n = v.shape[1]
    spec = fft.oneshot().rfft(v, axis=1).T[:, :, None]
    return fft.oneshot().irfft(np.matmul(cov[: len(spec)], spec)[:, :, 0].T, n=n, axis=1)


def circulant_solve(cov: np.ndarray, r: np.ndarray) -> np.ndarray:
    """S^-1 r for full streams ``r`` (M, nt/q): one dense solve per frequency j <= nt/(2q) (as circulant_apply)."""
    n = r.shape[1]
    spec = fft.oneshot().rfft(r, axis=1).T[:, :, None]
    return fft.oneshot().irfft(np.linalg.solve(cov[: len(spec)], spec)[:, :, 0].T, n=n, axis=1)


@dataclass(frozen=True)
class SolveReport:
    """How S x = r was solved: ``method`` 'circulant' (every sample observed) or 'pcg'; ``iterations`` of the
    conjugate gradients (0 for the direct solve) and the final relative residual |S x - r| / |r| [-]."""

    method: str
    iterations: int
    relative_residual: float


def solve(cov: np.ndarray, r: np.ndarray, observed: np.ndarray,
          preconditioner: np.ndarray | None = None) -> tuple[np.ndarray, SolveReport]:  # fmt: skip
    """x = S^-1 r on the observed samples, zero elsewhere: (x (M, nt), report); all observed: the exact per-frequency
    solve. Otherwise preconditioned conjugate gradients on the observed samples (ParameterError after
    CG_MAX_ITERATIONS), started from :func:`_gap_start` when many samples are missing."""
    pre = cov if preconditioner is None else preconditioner
    r = np.where(observed, r, 0.0)
    norm = float(np.linalg.norm(r))
    if observed.all():
        x = circulant_solve(cov, r)
        res = np.linalg.norm(circulant_apply(cov, x) - r) / norm if norm > 0 else 0.0
        return x, SolveReport("circulant", 0, float(res))
    if norm == 0:
        return np.zeros_like(r), SolveReport("pcg", 0, 0.0)
    inverse = np.linalg.inv(pre[: r.shape[1] // 2 + 1])  # the preconditioner's inverses once (Hermitian to round-off)
    inverse = 0.5 * (inverse + np.conj(np.swapaxes(inverse, 1, 2)))
    many_gaps = preconditioner is None and (~observed).sum() > GAP_START_FRACTION * observed.size
    x, start = _gap_start(inverse, r, observed) if many_gaps else (np.zeros_like(r), 0)
    return _pcg(cov, inverse, r, observed, x, start)


def _gap_start(inverse: np.ndarray, r: np.ndarray, observed: np.ndarray) -> tuple[np.ndarray, int]:
    """S_oo^-1 r through the precision T = S^-1 of the full streams: T_oo - T_om T_mm^-1 T_mo (Schur complement; T is
    far better conditioned on scattered gaps than S on the observed samples). Returns (x, iterations)."""
    missing = ~observed
    n = r.shape[1]
    weights = np.full(inverse.shape[0], 2.0)  # T's diagonal per stream: the mean of (S_j^-1)_aa over all j
    weights[0] = 1.0
    if n % 2 == 0:
        weights[-1] = 1.0
    diag = np.einsum("j,jaa->a", weights, inverse).real / n
    b = np.where(missing, circulant_apply(inverse, r), 0.0)
    y, it, _ = _conjugate_gradients(lambda v: np.where(missing, circulant_apply(inverse, v), 0.0),
                                    lambda v: np.where(missing, v / diag[:, None], 0.0), b, np.zeros_like(r), 1e-12)
    return np.where(observed, circulant_apply(inverse, r - y), 0.0), it


def _pcg(cov: np.ndarray, inverse: np.ndarray, r: np.ndarray, observed: np.ndarray, x: np.ndarray,
         start: int) -> tuple[np.ndarray, SolveReport]:  # fmt: skip
    """Conjugate gradients on S_oo x = r from ``x``, preconditioned by the circulant ``inverse``; ``start``: the
    iterations spent on ``x`` already (reported with these)."""
    x, it, rel = _conjugate_gradients(lambda v: np.where(observed, circulant_apply(cov, v), 0.0),
                                      lambda v: np.where(observed, circulant_apply(inverse, v), 0.0), r, x,
                                      CG_TOLERANCE)  # fmt: skip
    if rel <= CG_TOLERANCE:
        return x, SolveReport("pcg", start + it, rel)
    raise ParameterError(
        f"the conditioning system did not converge in {CG_MAX_ITERATIONS} conjugate-gradient iterations (relative "
        f"residual {rel:.2e} > {CG_TOLERANCE:g}): the measurements are nearly dependent or too many are missing for "
        "the preconditioner; give a noise level > 0"
    )


def _conjugate_gradients(apply, precondition, b: np.ndarray, x: np.ndarray,
                         tolerance: float) -> tuple[np.ndarray, int, float]:  # fmt: skip
    """Preconditioned conjugate gradients on A x = b from ``x`` (``apply``: A v; ``precondition``: M^-1 v, both
    zero outside the unknowns): (x, iterations, relative residual |b - A x| / |b| of the recursion), stopping at
    ``tolerance`` or after CG_MAX_ITERATIONS (the residual then above it)."""
    norm = float(np.linalg.norm(b))
    if norm == 0:
        return x, 0, 0.0
    res = b - apply(x)
    rel = float(np.linalg.norm(res)) / norm
    if rel <= tolerance:
        return x, 0, rel
    z = precondition(res)
    p, rz = z.copy(), float(np.vdot(res, z))
    for it in range(1, CG_MAX_ITERATIONS + 1):
        ap = apply(p)
        alpha = rz / float(np.vdot(p, ap))
        x = x + alpha * p
        res -= alpha * ap
        rel = float(np.linalg.norm(res)) / norm
        if rel <= tolerance:
            return x, it, rel
        z = precondition(res)
        rz_new = float(np.vdot(res, z))
        p = z + (rz_new / rz) * p
        rz = rz_new
    return x, CG_MAX_ITERATIONS, rel


def correction_blocks(stencil: MannStencil, streams: Streams, weights: np.ndarray, times_s, planes_out, ny: int,
                      nz: int, threads: int = 1) -> Iterator[tuple[range, np.ndarray]]:  # fmt: skip
    """Yield (slabs, yz-transformed cropped spectra (P_out, 3, len(slabs), ny, nz) complex64) of C H^T w; ``weights``
    (M, nt/q): one value per stream sample; the planes' rho_pq sums run by the Ornstein-Uhlenbeck recursion. The result
    does not depend on ``threads``."""
    box, backend = stencil.box, fft.backend()  # resolved once: every workspace with the same backend
    times = np.asarray(times_s, dtype=float)
    planes_out = list(planes_out)
    chain = sorted(set(planes_out) | {int(p) for p in streams.used_planes()}, key=lambda p: (times[p], p))
    steps = np.diff(times[chain])
    distinct, step_class = np.unique(steps, return_inverse=True)
    step_class = step_class.reshape(-1).astype(np.int64)
    where = {p: n for n, p in enumerate(chain)}
    rows = np.array([where[p] for p in planes_out], np.int64)  # the chain position of each wanted plane
    term_row = np.array([where[int(p)] for p in streams.plane[streams.term_stream]], dtype=np.int64)
    grid_index = np.ravel_multi_index((term_row, streams.term_component, streams.term_iy, streams.term_iz),
                                      (len(chain), 3, box.nyp, box.nzp))  # fmt: skip
    q, m = streams.decimation, streams.n_streams
    full = np.zeros((m, box.nt))
    for a in range(m):  # the samples at their stored time steps o_a + m q
        full[a, streams.offset[a] :: q] = weights[a]
    spec_w = fft.oneshot().rfft(full, axis=1)

    def group(transforms: tuple[_GroupFFT, _GroupFFT], slabs: range) -> np.ndarray:  # the group's block
        grid, plan = transforms[0].buffers(len(slabs))
        grid[...] = 0.0
        index = np.array(slabs, np.int64)
        kernels.scatter_terms(spec_w[:, index], streams.term_stream, grid_index, streams.term_shift,
                              streams.term_weight, index, box.nt, grid.reshape(len(slabs), -1))  # fmt: skip
        plan.execute()
        f = grid.reshape(len(slabs), len(chain), 3, -1)
        g, plan = transforms[1].buffers(len(slabs))
        for b, i in enumerate(slabs):
            inv_tau = slab_inv_tau(stencil, i)
            rho = (np.ones((len(distinct), box.nyp * box.nzp)) if inv_tau is None  # exp once per distinct step
                   else np.exp(-distinct[:, None] * inv_tau.reshape(1, -1)))  # fmt: skip
            kernels.chain_correction(f[b].view(np.float32), rho, step_class, _slab_phi(stencil, i), rows,
                                     g[b].reshape(len(planes_out), 3, -1).view(np.float32))  # fmt: skip
        plan.execute()  # unnormalised: sum_(j, l) e^(+2 pi i (j y / nyp + l z / nzp))
        return np.moveaxis(g[..., :ny, :nz], 0, 2).copy()

    def workspace() -> tuple[_GroupFFT, _GroupFFT]:
        back = _GroupFFT((len(planes_out), 3, box.nyp, box.nzp), backend, "c2c_backward", keep_z=nz)
        rows = (int(streams.term_iy.min()), int(streams.term_iy.max()) + 1)  # H^T w is zero on the other rows
        return _GroupFFT((len(chain), 3, box.nyp, box.nzp), backend, rows=rows), back

    groups = [range(s0, min(s0 + SLAB_GROUP, box.nk1)) for s0 in range(0, box.nk1, SLAB_GROUP)]
    yield from zip(groups, _ordered_map(group, groups, threads, workspace))


def workspace_bytes(box, streams: Streams, n_out: int) -> int:
    """Bytes of the larger slab-group workspace of :func:`stream_covariance` and :func:`correction_blocks` (for
    ``n_out`` planes out)."""
    keys = _keys(streams)
    n_dir = len(keys.directions)
    n_pairs = n_dir * (n_dir + 1) // 2
    basis = _basis(keys.directions).n
    points, half = box.nyp * box.nzp, box.nyp * (box.nzp // 2 + 1)
    lag = basis * (4 * points * 8 + half * 16) + n_pairs * half * 16  # psi, inputs (whole plane: twice), spectra
    chain = n_out + len(streams.used_planes())
    correction = SLAB_GROUP * (chain + 2 * n_out) * 3 * points * 8
    return max(lag, correction)
