"""Welch estimates from a field store, computed with dask over the store's time chunks.

One task reads one plane over one *span* (whole time chunks) and returns small sums; Welch segments (Hann, 50 %
overlap, mean removed) straddling two spans are not used. Estimated: point moments, one-point and u-w spectra, yz
and plane-pair cross-spectra, and the rotor-effective wind speed (Guo et al. 2023, Eq. 23 on the grid)."""

from __future__ import annotations

import math
import os
import sys
import threading
from dataclasses import dataclass, field
from functools import cached_property

import dask
import numpy as np
from scipy.signal import get_window
from dask.callbacks import Callback
from tqdm import tqdm

from turbgen import fft
from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.store.chunk_files import empty_aligned
from turbgen.validation.point_sets import (LONG_POINTS_PER_AXIS, check_rotor_radius, default_separations,
                                           long_sublattice, rotor_mask)
from turbgen.validation.span_sums import COMPONENTS, span_sums

SPAN_SEGMENTS = 4  # a span holds at least this many segment lengths (fewer segments lost at span edges)
LONG_BYTES_PER_TASK = 8 * 2**20  # plane-pair spectra per task at most 8 MiB (nx tasks wait for the pair sums)
MIN_NPERSEG = 32
MAX_NPERSEG = 4096  # long records: more segments rather than ever finer bins (4096 x 0.5 s: 0.49 mHz)
SPAN_BYTES = 256 * 2**20  # a task's u, v, w data stay below this unless one segment needs more


@dataclass(frozen=True)
class WelchSetup:
    """Welch segment length ``nperseg`` [samples] at time step ``dt_s``; Hann window, 50 % overlap."""

    nperseg: int
    dt_s: float

    @property
    def hop(self) -> int:
        return self.nperseg // 2

    @cached_property
    def window(self) -> np.ndarray:
        """Periodic Hann window (float64): w_n = 1/2 - 1/2 cos(2 pi n / N), n = 0 .. N - 1 (scipy's get_window)."""
        return get_window("hann", self.nperseg, fftbins=True)

    @property
    def freqs(self) -> np.ndarray:
        """Welch bin frequencies [Hz], 0 .. 1/(2 dt)."""
        return fft.rfftfreq(self.nperseg, self.dt_s)

    @property
    def scale(self) -> np.ndarray:
        """Per-bin factor turning sum |X|^2 into a one-sided PSD: 2 dt / sum w^2 (1x at 0 and Nyquist)."""
        s = np.full(self.nperseg // 2 + 1, 2.0 * self.dt_s / np.sum(self.window**2))
        s[0] *= 0.5
        if self.nperseg % 2 == 0:
            s[-1] *= 0.5
        return s

    @cached_property
    def overlap_rho2(self) -> float:
        """Correlation of the periodograms of two half-overlapping segments (white noise): 1/36 for Hann."""
        w = self.window
        return float(np.sum(w[self.hop :] * w[: self.nperseg - self.hop]) ** 2 / np.sum(w**2) ** 2)

    def bin_rho2(self, lag: int, shift: int = 0) -> float:
        """Correlation of white noise's periodogram bins ``lag`` apart in segments ``shift`` samples apart (Hann: 1,
        4/9, 1/36 in one segment; 1/36, 0.020, 0.0069, 8e-4 half-overlapping, not 1/36 times those as Welch 1967)."""
        w, n = self.window, self.nperseg
        g = w[shift:] * w[: n - shift] * np.exp(-2j * np.pi * lag * np.arange(n - shift) / n)
        return float(np.abs(g.sum()) ** 2 / np.sum(w**2) ** 2)

    def effective_segments(self, n_segments: int, n_overlapping_pairs: int) -> float:
        """Number of independent periodograms equivalent to the average (Welch 1967, Eq. of the variance)."""
        return n_segments / (1.0 + 2.0 * self.overlap_rho2 * n_overlapping_pairs / n_segments)


def default_nperseg(nt: int) -> int:
    """Default Welch segment length [samples] for ``nt`` samples: the largest power of two <= nt / 8 (~15
    segments) in [MIN_NPERSEG, MAX_NPERSEG]; ParameterError if nt < 4 MIN_NPERSEG."""
    if nt < 4 * MIN_NPERSEG:
        raise ParameterError(f"nt = {nt} is too short to validate (needs >= {4 * MIN_NPERSEG} time steps)")
    return min(2 ** int(math.floor(math.log2(nt / 8))) if nt >= 8 * MIN_NPERSEG else MIN_NPERSEG, MAX_NPERSEG)


def plan_spans(nt: int, chunk_t: int, nperseg: int, bytes_per_sample: int = 0) -> list[tuple[int, int]]:
    """[t0, t1) spans of whole chunks, each >= SPAN_SEGMENTS x nperseg samples if that fits SPAN_BYTES
    (u, v, w of one plane: ``bytes_per_sample`` per time step), else >= nperseg; the last one merged if short."""
    target = SPAN_SEGMENTS * nperseg
    if bytes_per_sample > 0:
        target = max(nperseg, min(target, SPAN_BYTES // bytes_per_sample))
    group = max(1, math.ceil(target / chunk_t))
    step = group * chunk_t
    spans = [(t0, min(nt, t0 + step)) for t0 in range(0, nt, step)]
    if len(spans) > 1 and spans[-1][1] - spans[-1][0] < nperseg:
        spans[-2:] = [(spans[-2][0], nt)]
    return spans


def segment_starts(length: int, setup: WelchSetup) -> range:
    """Start samples of the half-overlapping segments of ``setup`` inside a record of ``length`` samples."""
    return range(0, length - setup.nperseg + 1, setup.hop)


def long_points_per_axis(setup: WelchSetup, spans) -> int:
    """Sub-lattice points per axis such that one task's kept spectra (segments x bins x points, complex64)
    fit in LONG_BYTES_PER_TASK."""
    n_seg = max(len(segment_starts(t1 - t0, setup)) for t0, t1 in spans)
    per_point = max(n_seg, 1) * (setup.nperseg // 2 + 1) * 8
    return int(max(2, min(LONG_POINTS_PER_AXIS, math.isqrt(max(LONG_BYTES_PER_TASK // per_point, 1)))))


@dataclass
class Estimates:
    """Everything the validator estimated from one store (spectra one-sided, [m^2 s^-2 Hz^-1])."""

    setup: WelchSetup
    grid: Grid
    separations: tuple[tuple[int, int], ...]
    rotor_radius_m: float
    rotor_mask: np.ndarray
    long_iy: np.ndarray
    long_iz: np.ndarray
    n_segments: int = 0  # segments per point (all spans)
    n_overlapping_pairs: int = 0  # pairs of consecutive half-overlapping segments
    starts: tuple = ()  # start sample of every averaged segment (for the exact Welch covariance)
    mean: dict = field(default_factory=dict)  # component -> grand mean [m/s]
    variance: dict = field(default_factory=dict)  # component -> mean per-point variance [m^2 s^-2]
    auto: dict = field(default_factory=dict)  # component -> (nf,) PSD
    uw: np.ndarray | None = None  # (nf,) complex cross-spectrum  E[conj(X_u) X_w]
    yz: dict = field(default_factory=dict)  # component -> {(a, b): (C complex, A, B)} (nf,) each
    long_cross: np.ndarray | None = None  # (nx, nx, nf) complex, E[conj(X_p) X_q]
    long_auto: np.ndarray | None = None  # (nx, nf)
    rews: np.ndarray | None = None  # (nt, nx) rotor-effective wind speed series [m/s]
    rews_psd: np.ndarray | None = None  # (nf,) averaged over planes
    rews_segments: int = 0
    rews_overlapping_pairs: int = 0

    @property
    def freqs(self) -> np.ndarray:
        return self.setup.freqs

    @property
    def effective_segments(self) -> float:
        return self.setup.effective_segments(self.n_segments, self.n_overlapping_pairs)

    @property
    def rews_effective_segments(self) -> float:
        return self.setup.effective_segments(self.rews_segments, self.rews_overlapping_pairs)


class _ReadBuffers:
    """float32 (t, ny, nz) buffers per thread and component, reused by the tasks of one run: the chunks are
    decoded straight into them (no copy and no fresh pages per task)."""

    def __init__(self, shape: tuple[int, int, int]):
        self.shape = shape
        self._local = threading.local()

    def get(self, component: str, n_t: int) -> np.ndarray:
        """This thread's buffer of ``component``, its first ``n_t`` time steps."""
        bufs = self._local.__dict__.setdefault("bufs", {})
        if component not in bufs:
            bufs[component] = empty_aligned(self.shape, np.float32)  # page-aligned: direct reads need no bounce
        return bufs[component][:n_t]


def _task(fs, buffers: _ReadBuffers, ix: int, t0: int, t1: int, setup: WelchSetup, seps, mask, iy, iz) -> dict:
    """Sums of one plane over one span [t0, t1) (``span_sums``): each stored chunk is read once
    (FieldStore.read_span: corrupted chunks, NaN and implausible values give a one-line StoreError)."""
    data = {c: fs.read_span(c, ix, t0, t1, out=buffers.get(c, t1 - t0)) for c in COMPONENTS}
    return span_sums(data, setup.window, segment_starts(t1 - t0, setup), seps, mask, iy, iz)  # keeps no view of data


def _without_sub(part: dict) -> dict:
    return {k: v for k, v in part.items() if k != "sub"}


def _plane_pairs(subs: list[np.ndarray]) -> np.ndarray:
    """Cross-spectra sums (nx, nx, nf) between the planes of one span: sum over segments, points of conj(X_p) X_q."""
    x = np.stack(subs)  # (nx, nseg, nf, P)
    cross = np.empty((x.shape[0], x.shape[0], x.shape[2]), complex)
    for p in range(x.shape[0]):
        cross[p] = np.einsum("sfk,qsfk->qf", np.conj(x[p]), x)
    return cross


def welch_series(x: np.ndarray, setup: WelchSetup) -> tuple[np.ndarray, int, int]:
    """One-sided Welch PSD (Welch 1967) of the (nt, m) series ``x`` [m/s], averaged over segments and columns:
    (psd [m^2 s^-2 Hz^-1], segments per column, overlapping segment pairs per column)."""
    starts = segment_starts(x.shape[0], setup)
    w = setup.window[:, None]
    acc = np.zeros(setup.nperseg // 2 + 1)
    for s in starts:
        seg = x[s : s + setup.nperseg]
        spec = fft.oneshot().rfft((seg - seg.mean(axis=0)) * w, axis=0)
        acc += (np.abs(spec) ** 2).mean(axis=1)
    k = len(starts)
    return acc * setup.scale / k, k, max(k - 1, 0)


class _TqdmCallback(Callback):
    """dask progress on a tqdm bar (stderr, only when it is a terminal)."""

    def __init__(self, total: int, desc: str):
        super().__init__()
        self.bar = tqdm(total=total, desc=desc, unit="task", disable=not sys.stderr.isatty())

    def _posttask(self, key, result, dsk, state, worker_id):
        self.bar.update(1)

    def _finish(self, dsk, state, errored):
        self.bar.close()


def plan_estimates(fs, *, rotor_radius_m: float | None = None, nperseg: int | None = None,
                   separations=None) -> Estimates:
    """The sampling design of a store's estimates, before any data is read (sums still empty); ParameterError if
    ``nperseg`` [samples] is outside [MIN_NPERSEG, nt / 2] or the rotor radius does not fit."""
    g = fs.grid
    setup = WelchSetup(nperseg or default_nperseg(g.nt), g.dt_s)
    if not MIN_NPERSEG <= setup.nperseg <= g.nt // 2:
        raise ParameterError(f"nperseg = {setup.nperseg} is outside [{MIN_NPERSEG}, nt/2 = {g.nt // 2}]")
    radius = check_rotor_radius(g, rotor_radius_m)
    seps = tuple(separations) if separations is not None else default_separations(g)
    spans = _spans(fs, setup)
    per_axis = long_points_per_axis(setup, spans)
    iy, iz = long_sublattice(g.ny, per_axis), long_sublattice(g.nz, per_axis)
    est = Estimates(setup, g, seps, radius, rotor_mask(g, radius), iy, iz)
    # segments lie inside one span each (module docstring); the REWS series is one record
    est.starts = tuple(t0 + s for t0, t1 in spans for s in segment_starts(t1 - t0, setup))
    est.n_segments = len(est.starts)
    est.n_overlapping_pairs = sum(max(len(segment_starts(t1 - t0, setup)) - 1, 0) for t0, t1 in spans)
    est.rews_segments = len(segment_starts(g.nt, setup))
    est.rews_overlapping_pairs = max(est.rews_segments - 1, 0)
    return est


def _spans(fs, setup: WelchSetup) -> list[tuple[int, int]]:
    g = fs.grid
    return plan_spans(g.nt, fs.chunk_t, setup.nperseg, 3 * 4 * g.ny * g.nz)


def run_estimates(fs, est: Estimates, workers: int | None = None) -> Estimates:
    """Fill the planned estimates ``est`` (:func:`plan_estimates`) in place from the store, one dask task per (span,
    plane) on ``workers`` threads (default the CPU count); returns ``est``."""
    g, setup = est.grid, est.setup
    spans = _spans(fs, setup)
    buffers = _ReadBuffers((max(t1 - t0 for t0, t1 in spans), g.ny, g.nz))
    task = dask.delayed(_task, pure=False)
    pairs = dask.delayed(_plane_pairs, pure=False)
    strip = dask.delayed(_without_sub, pure=False)
    per_span = []
    for t0, t1 in spans:
        parts = [task(fs, buffers, ix, t0, t1, setup, est.separations, est.rotor_mask, est.long_iy, est.long_iz)
                 for ix in range(g.nx)]
        # the kept sub-lattice spectra feed the plane-pair sums only; the output holds the small sums
        per_span.append(([strip(p) for p in parts], pairs([p["sub"] for p in parts])))
    with _TqdmCallback(total=len(spans) * (g.nx * 3 + 1), desc="validate"):
        results = dask.compute(per_span, scheduler="threads", num_workers=workers or os.cpu_count())[0]
    _combine(est, spans, results)
    return est


def _combine(est: Estimates, spans, results) -> None:
    """Add the per-task sums into the normalised estimates."""
    g, setup, seps, n_seg = est.grid, est.setup, est.separations, est.n_segments
    nf = setup.nperseg // 2 + 1
    scale = setup.scale
    norm = scale / (n_seg * g.ny * g.nz * g.nx)
    sums = {c: np.zeros((g.nx, g.ny, g.nz)) for c in COMPONENTS}
    sums2 = {c: np.zeros((g.nx, g.ny, g.nz)) for c in COMPONENTS}
    auto = {c: np.zeros(nf) for c in COMPONENTS}
    yz = {c: {s: [np.zeros(nf, complex), np.zeros(nf), np.zeros(nf)] for s in seps} for c in COMPONENTS}
    uw = np.zeros(nf, complex)
    long_cross = np.zeros((g.nx, g.nx, nf), complex)
    rews = np.zeros((g.nt, g.nx))
    for (t0, t1), (parts, cross) in zip(spans, results):
        long_cross += cross
        for ix, r in enumerate(parts):
            rews[t0:t1, ix] = r["rews"]
            uw += r["uw"]
            for c in COMPONENTS:
                sums[c][ix] += r["sum"][c]
                sums2[c][ix] += r["sum2"][c]
                auto[c] += r["auto"][c]
                for s in seps:
                    for k in range(3):
                        yz[c][s][k] += r["yz"][c][s][k]
    for c in COMPONENTS:
        point_mean = sums[c] / g.nt
        est.mean[c] = float(point_mean.mean())
        est.variance[c] = float((sums2[c] / g.nt - point_mean**2).mean())
        est.auto[c] = auto[c] * norm
        est.yz[c] = {(a, b): tuple(v * scale / ((g.ny - a) * (g.nz - b) * g.nx * n_seg) for v in yz[c][(a, b)])
                     for a, b in seps}  # (C, A, B) per pair and segment
    est.uw = uw * norm
    n_sub = est.long_iy.size * est.long_iz.size
    est.long_cross = long_cross * scale / (n_seg * n_sub)
    est.long_auto = np.real(np.einsum("ppf->pf", est.long_cross))
    est.rews = rews
    est.rews_psd = welch_series(rews, setup)[0]  # segment counts: planned
