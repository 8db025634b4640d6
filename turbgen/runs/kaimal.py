"""One Kaimal 4D run (turbgen.spec.kaimal.KaimalRun): KaimalEvo -> store; shared by the CLI, sweep and service."""

from __future__ import annotations

import collections
import contextlib
import math
import shutil
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.resources import available_memory_bytes, format_bytes, require_memory
from turbgen.runs.models import Model
from turbgen.runs.scratch import FileSpectrum
from turbgen.spec.kaimal import KaimalRun
from turbgen.store import create_store
from turbgen.store.memory import MemoryWriter
from turbgen.synthesis.kaimal_evo import (COMPONENTS, FREQ_CHUNK, InMemorySpectrum, KaimalEvo, PlaneRing,
                                          resolved_band_hz)
from turbgen.synthesis.random_streams import keyed_complex_normal


def kaimal_generator(run: KaimalRun, workers: int | None = None, keep: bool = False) -> KaimalEvo:
    """The synthesis object of ``run`` (``workers``: FFT threads, no effect on the field; ``keep``: its seed-free
    part kept for KaimalEvo.reseeded)."""
    return KaimalEvo(run.kaimal, run.grid, run.U_m_s, run.seed, long_coherence=run.long_coherence(),
                     long_components=run.long_components, coherent_vw=run.vw_coherence == "exp",
                     rescale=run.rescale, workers=workers, keep=keep, yz_coherence=run.coherence,
                     variances=None if run.spectrum is None else run.spectrum.line_variances())


def store_attrs(run: KaimalRun, gen: KaimalEvo | None = None) -> dict:
    """The store attributes of ``run`` with what its generator (``gen``, if built) derives: resolved band [Hz],
    expected sigma [m/s], rescale factors and frequency chunk."""
    gen = gen or kaimal_generator(run)
    lo, hi = resolved_band_hz(run.grid.nt, run.grid.dt_s)
    return run.to_attrs({
        "resolved_band_hz": [lo, hi],
        "expected_sigma_m_s": [math.sqrt(gen.expected_variance(c)) for c in COMPONENTS],
        "rescale_factors": [gen.rescale_factors[c] for c in COMPONENTS],
        "freq_chunk": FREQ_CHUNK,
    })


# components in the order they are made: u last, whose yz coherence (by default the only one) makes its frequency
# chunks the longest phase of a run, long enough to write w's planes meanwhile (the store's writes are bound by the
# disk); the field does not depend on the order
ORDER = ("v", "w", "u")
MAX_WRITE_BACKLOG = 8  # planes whose store writes may lag behind the synthesis (at most; ring_planes)


def ring_planes(grid: Grid, spill: bool = False) -> int:
    """Planes of the run's PlaneRing: two transformed ahead, the one yielded and up to MAX_WRITE_BACKLOG waiting for
    the store (one when spilled)."""
    return 3 + (1 if spill else min(grid.nx, MAX_WRITE_BACKLOG))


def memory_needed(grid: Grid, spill: bool = False, sampler: int = 0) -> int:
    """Peak bytes [B] of a run's arrays: one component's spectrum (``spill``: one frequency chunk of all planes and
    its mixing copies), the PlaneRing, and the larger of one chunk's yz samplers (``sampler``:
    KaimalEvo.sampler_bytes) and the spectrum copies of the two planes transformed at once."""
    g, nf = grid, grid.nt // 2 + 1
    in_flight = PlaneRing.bytes_needed(g.nt, g.ny, g.nz, ring_planes(g, spill)) + max(3 * nf * g.ny * g.nz * 8, sampler)
    if spill:
        return 3 * InMemorySpectrum.bytes_needed(g.nx, FREQ_CHUNK, g.ny, g.nz) + in_flight
    return spectrum_bytes(g) + in_flight


def spectrum_bytes(grid: Grid) -> int:
    """Bytes [B] of one component's spectrum (nx, nf, ny, nz) complex64 (in memory or the scratch file)."""
    return InMemorySpectrum.bytes_needed(grid.nx, grid.nt // 2 + 1, grid.ny, grid.nz)


def plan_spill(grid: Grid, out: Path, spill: bool | None, sampler: int) -> bool:
    """Whether the spectrum goes to a scratch file next to ``out`` (``spill`` None: when memory_needed exceeds 80 %
    of the available memory). ParameterError if it fits neither memory nor, spilled, the disk."""
    what = f"the Kaimal spectrum ({grid.nx} planes x {grid.nt // 2 + 1} bins x {grid.ny} x {grid.nz})"
    if spill is None:
        available = available_memory_bytes()
        spill = available is not None and memory_needed(grid, sampler=sampler) > 0.8 * available
    require_memory(memory_needed(grid, spill, sampler), what, "lower `nt`, `ny`/`nz` or the number of planes")
    if spill:
        free = shutil.disk_usage(out.parent).free
        if spectrum_bytes(grid) + 3 * grid.nbytes_per_component() > free:
            raise ParameterError(
                f"{what} does not fit in memory and its {format_bytes(spectrum_bytes(grid))} scratch file plus "
                f"the store do not fit on the disk of {out.parent} ({format_bytes(free)} free); lower `nt`, "
                "`ny`/`nz` or the number of planes"
            )
    return spill


def _touch_while_loading_noise(pool: ThreadPoolExecutor, ring: PlaneRing, spectrum: InMemorySpectrum | None) -> None:
    """Touch the spectrum (in ``pool``) and the ring while this thread loads the compiled noise (as
    runs.mann._touch_while_loading_kernels); returns when all is touched."""
    # spilled (no spectrum): the spectrum is a file
    touched = pool.submit(ring.touch) if spectrum is None else pool.submit(np.copyto, spectrum.data, 0)
    keyed_complex_normal((0,), np.empty(1, dtype=np.complex64))  # the stream is discarded: only the load counts
    if spectrum is not None:
        ring.touch()
    touched.result()


def _fill(w, run: KaimalRun, gen: KaimalEvo, spill: bool, scratch_dir: Path | None, progress: bool) -> dict:
    """Every plane of ``run`` into the writer ``w``, the synthesis report added to its attributes; returns {component:
    [sum of squares, count]}. ``spill``: spectra in a scratch file in ``scratch_dir``."""
    g = run.grid
    sums = {c: [0.0, 0] for c in COMPONENTS}
    with contextlib.ExitStack() as stack:
        # one spectrum buffer for the three components in turn
        if spill:
            buffer = stack.enter_context(FileSpectrum(scratch_dir, g.nx, gen.nf, g.ny, g.nz))
        else:
            buffer = InMemorySpectrum(g.nx, gen.nf, g.ny, g.nz)
        tick = None
        if progress:  # tqdm is imported only then (CLI start-up)
            from tqdm import tqdm

            bar = stack.enter_context(tqdm(total=3 * (gen.n_chunks + g.nx), desc="kaimal", unit="step"))
            tick = lambda: bar.update(1)  # noqa: E731
        # Planes written (and summed) in the background, in order, while the next are made; leaving the pool
        # waits for the writes, so an exception never races the store's clean-up.
        background = stack.enter_context(ThreadPoolExecutor(1))
        ring = PlaneRing(g.nt, g.ny, g.nz, ring_planes(g, spill))
        _touch_while_loading_noise(background, ring, None if spill else buffer)
        pending = collections.deque()

        def write_and_sum(c, ix, plane):
            sums[c][0] += w.write(c, ix, plane, squares=True)[1]  # the sum of squares of its finiteness check
            sums[c][1] += plane.size

        for c in ORDER:
            for ix, plane in gen.component_planes(c, tick=tick, spectrum=buffer, ring=ring):
                pending.append(background.submit(write_and_sum, c, ix, plane))
                while len(pending) > ring.size - 3:  # the ring's condition: plane k's buffer serves plane k + size
                    pending.popleft().result()
        while pending:
            pending.popleft().result()
    # clipping of any embedding is recorded with the field, never only printed
    w.add_attrs(synthesis_report=gen.report)
    return sums


def _summary(gen: KaimalEvo, sums: dict, path, t0: float, spill: bool) -> dict:
    summary = {"path": None if path is None else str(path), "seconds": time.perf_counter() - t0, "spilled": spill}
    for c in COMPONENTS:
        summary[f"sigma_{c}"] = math.sqrt(sums[c][0] / sums[c][1])
    summary["expected_sigma"] = [math.sqrt(gen.expected_variance(c)) for c in COMPONENTS]
    summary.update(gen.report)
    return summary


def run_kaimal(run: KaimalRun, out, *, overwrite: bool = False, chunk_t: int | None = None,
               progress: bool = False, threads: int | None = None, spill: bool | None = None,
               gen: KaimalEvo | None = None) -> dict:
    """Generate the field of ``run`` into the store ``out``; return a summary dict.

    ``threads``: FFT workers (default all cores). ``spill``: each component's spectrum in an unlinked scratch file
    next to ``out`` (None: when it would not fit in 80 % of the available memory). Neither changes the field.
    ``gen``: this run's generator, if built. Summary: path, sigma_u/v/w and expected_sigma [m/s], seconds, spilled
    and the synthesis report (yz_clip_error, long_clip_error: 0 when exact)."""
    g = run.grid
    out = Path(out)
    gen = gen or kaimal_generator(run, workers=threads)
    spill = plan_spill(g, out.absolute(), spill, gen.sampler_bytes())
    attrs = store_attrs(run, gen)
    t0 = time.perf_counter()
    with create_store(Path(out), g, attrs, chunk_t=chunk_t, overwrite=overwrite) as w:
        sums = _fill(w, run, gen, spill, out.absolute().parent, progress)
    return _summary(gen, sums, w.path, t0, spill)


def in_memory_bytes(run: KaimalRun, gen: KaimalEvo | None = None) -> int:
    """Bytes [B] kaimal_in_memory allocates: memory_needed (spectrum in memory) and the field's 3 float32 components."""
    gen = gen or kaimal_generator(run)
    return memory_needed(run.grid, sampler=gen.sampler_bytes()) + 3 * run.grid.nbytes_per_component()


def kaimal_in_memory(run: KaimalRun, *, progress: bool = False, threads: int | None = None,
                     gen: KaimalEvo | None = None):
    """The field of ``run`` in memory as run_kaimal's store would open (but ``created_utc``): (xarray.Dataset,
    summary with path None). ParameterError when in_memory_bytes exceeds the available memory."""
    gen = gen or kaimal_generator(run, workers=threads)
    g = run.grid
    require_memory(in_memory_bytes(run, gen), f"the Kaimal run ({g.nx} planes x {g.nt} x {g.ny} x {g.nz}) and its "
                   "field in memory", "lower `nt`, `ny`/`nz` or the number of planes")  # fmt: skip
    attrs = store_attrs(run, gen)
    t0 = time.perf_counter()
    with MemoryWriter(g, attrs) as w:
        sums = _fill(w, run, gen, False, None, progress)
    return w.dataset, _summary(gen, sums, None, t0, False)


def _run(run: KaimalRun, out, *, overwrite=False, chunk_t=None, threads=None, memory_bytes=None, shared=None):
    return run_kaimal(run, out, overwrite=overwrite, chunk_t=chunk_t, threads=threads)


def _memory(run: KaimalRun, threads: int) -> int:
    return memory_needed(run.grid, sampler=kaimal_generator(run, workers=threads).sampler_bytes())


def _least_memory(run: KaimalRun) -> int:
    floor = min(memory_needed(run.grid), memory_needed(run.grid, True))  # memory or disk, samplers not counted
    available = available_memory_bytes()
    if available is not None and floor > available:
        # the samplers only add: refused without planning a torus per frequency (minutes for 8 M bins)
        return floor
    sampler = kaimal_generator(run, workers=1).sampler_bytes()
    return min(memory_needed(run.grid, sampler=sampler), memory_needed(run.grid, True, sampler))


MODEL = Model("kaimal", KaimalRun, _run, _memory, _least_memory, "`nt`, `ny`/`nz` or the number of planes",
              lambda run, threads, memory_bytes: None)
