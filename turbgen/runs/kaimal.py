"""Generating one Kaimal 4D run (turbgen.spec.kaimal.KaimalRun): KaimalEvo -> field store.

Used by ``turbgen kaimal``, the sweep and the service, so all give bit-identical stores for the same run.
"""

from __future__ import annotations

import contextlib
import math
import shutil
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path


from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.resources import available_memory_bytes, format_bytes, require_memory
from turbgen.runs.scratch import FileSpectrum
from turbgen.spec.kaimal import KaimalRun
from turbgen.store import create_store
from turbgen.synthesis.kaimal_evo import COMPONENTS, FREQ_CHUNK, InMemorySpectrum, KaimalEvo, PlaneRing, resolved_band_hz

def kaimal_generator(run: KaimalRun, workers: int | None = None) -> KaimalEvo:
    """The synthesis object of ``run`` (``workers``: FFT threads; the field does not depend on them)."""
    return KaimalEvo(run.kaimal, run.grid, run.U_m_s, run.seed, long_coherence=run.long_coherence(),
                     long_components=run.long_components, coherent_vw=run.vw_coherence == "exp",
                     rescale=run.rescale, workers=workers)


def store_attrs(run: KaimalRun, gen: KaimalEvo | None = None) -> dict:
    """The store attributes of ``run`` with what its generator derives: resolved band [Hz], expected
    sigma [m/s] per component, rescale factors and the frequency chunk (``gen``: this run's generator,
    if already built)."""
    gen = gen or kaimal_generator(run)
    lo, hi = resolved_band_hz(run.grid.nt, run.grid.dt_s)
    return run.to_attrs({
        "resolved_band_hz": [lo, hi],
        "expected_sigma_m_s": [math.sqrt(gen.expected_variance(c)) for c in COMPONENTS],
        "rescale_factors": [gen.rescale_factors[c] for c in COMPONENTS],
        "freq_chunk": FREQ_CHUNK,
    })


def memory_needed(grid: Grid, spill: bool = False, sampler: int = 0) -> int:
    """Peak bytes of a run's arrays: one component's spectrum (nx, nf, ny, nz) complex64 -- or, with
    ``spill`` (the spectrum in a scratch file), one frequency chunk of all planes with its mixing
    copies -- plus the larger of the yz samplers of one chunk (``sampler``: KaimalEvo.sampler_bytes, made
    before the transforms) and the planes in flight (two transformed at once, each with its spectrum copy, one
    yielded and one written by the store)."""
    nf = grid.nt // 2 + 1
    plane = grid.ny * grid.nz
    in_flight = max(3 * nf * plane * 8 + 5 * grid.nt * plane * 4, sampler)
    if spill:
        return 3 * grid.nx * FREQ_CHUNK * plane * 8 + in_flight
    return grid.nx * nf * plane * 8 + in_flight


def spectrum_bytes(grid: Grid) -> int:
    """Bytes of one component's spectrum (nx, nf, ny, nz) complex64 (in memory, or the scratch file)."""
    return grid.nx * (grid.nt // 2 + 1) * grid.ny * grid.nz * 8


def _plan_spill(grid: Grid, out: Path, spill: bool | None, sampler: int) -> bool:
    """Whether the spectrum goes to a scratch file next to ``out``; checks memory (and disk) first."""
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


def run_kaimal(run: KaimalRun, out, *, overwrite: bool = False, chunk_t: int | None = None,
               progress: bool = False, threads: int | None = None, spill: bool | None = None) -> dict:
    """Generate the field of ``run`` into the store ``out``; return a summary dict.

    ``threads``: FFT workers (default all cores); the field does not depend on it.
    ``spill``: keep each component's spectrum in an unlinked scratch file next to ``out`` instead
    of memory (None: only when it would not fit in 80 % of the available memory); the field is the same.

    Summary: path, sigma_u/v/w (realised, all points and planes) [m/s], expected_sigma [m/s],
    seconds, and the synthesis report (yz_clip_error, long_clip_error: 0 when exact).
    """
    g = run.grid
    out = Path(out)
    gen = kaimal_generator(run, workers=threads)
    spill = _plan_spill(g, out.absolute(), spill, gen.sampler_bytes())
    attrs = store_attrs(run, gen)
    t0 = time.perf_counter()
    sums = {c: [0.0, 0] for c in COMPONENTS}
    with create_store(Path(out), g, attrs, chunk_t=chunk_t, overwrite=overwrite) as w, contextlib.ExitStack() as stack:
        # one spectrum buffer for the three components in turn
        if spill:
            buffer = stack.enter_context(FileSpectrum(out.absolute().parent, g.nx, gen.nf, g.ny, g.nz))
        else:
            buffer = InMemorySpectrum(g.nx, gen.nf, g.ny, g.nz)
        tick = None
        if progress:  # tqdm is imported only then (CLI start-up)
            from tqdm import tqdm

            bar = stack.enter_context(tqdm(total=3 * (gen.n_chunks + g.nx), desc="kaimal", unit="step"))
            tick = lambda: bar.update(1)  # noqa: E731
        # One plane written (and summed) in the background while the next is made; leaving the pool waits
        # for that write, so an exception never races the store's clean-up.
        background = stack.enter_context(ThreadPoolExecutor(1))
        pending = None

        def write_and_sum(c, ix, plane):
            sums[c][0] += w.write(c, ix, plane, squares=True)[1]  # the sum of squares of its finiteness check
            sums[c][1] += plane.size

        ring = PlaneRing(g.nt, g.ny, g.nz)  # valid here: plane k's write is awaited when plane k + 1 arrives
        for c in COMPONENTS:
            for ix, plane in gen.component_planes(c, tick=tick, spectrum=buffer, ring=ring):
                if pending is not None:
                    pending.result()
                pending = background.submit(write_and_sum, c, ix, plane)
        if pending is not None:
            pending.result()
        # clipping of any embedding is recorded with the field, never only printed
        w.add_attrs(synthesis_report=gen.report)
        path = w.path
    summary = {"path": str(path), "seconds": time.perf_counter() - t0, "spilled": spill}
    for c in COMPONENTS:
        summary[f"sigma_{c}"] = math.sqrt(sums[c][0] / sums[c][1])
    summary["expected_sigma"] = [math.sqrt(gen.expected_variance(c)) for c in COMPONENTS]
    summary.update(gen.report)
    return summary
