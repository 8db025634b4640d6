"""One Mann space-time run (turbgen.spec.mann.MannRun): stencil -> snapshots -> zarr store.

Shared by ``turbgen mann``, the sweep and the service (bit-identical stores); the stencil depends on all but the
seed and can be shared between seeds."""

from __future__ import annotations

import functools
import math
import os
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
from tqdm import tqdm

from turbgen.errors import ParameterError
from turbgen.resources import default_threads, format_bytes, require_memory
from turbgen.runs.models import Model
from turbgen.runs.stencil_cache import cached_stencil
from turbgen.spec.mann import MannRun
from turbgen.store import create_store
from turbgen.store.memory import MemoryWriter
from turbgen.synthesis.mann_spacetime import COMPONENTS, MannSnapshots
from turbgen.synthesis.mann_stencil import MannStencil, build_stencil, stencil_nbytes, synthesis_box
from turbgen.synthesis.random_streams import complex_normal

_BUILD_SCRATCH = 64 * 2**20  # float64 temporaries of the stencil-building batches (all threads)


def build_mann_stencil(run: MannRun, cache_dir: str | Path | None = None, *, energy: str = "scaled") -> MannStencil:
    """The stencil of ``run`` in memory (the same for runs differing only in seed; ``energy="unit"``: also in
    ae, through MannStencil.scaled), built or read from the stencil cache ``cache_dir`` (the same numbers)."""
    box, evolving = synthesis_box(run), run.grid.nx > 1
    if cache_dir is None:
        return build_stencil(run.params, box, energy=energy, evolving=evolving)
    return cached_stencil(run.params, box, cache_dir, energy=energy, evolving=evolving)


def shared_stencil_key(run: MannRun) -> tuple:
    """What the unit stencil of ``run`` depends on (hashable): runs with equal keys share it (the sweep)."""
    return run.params.with_ae(1.0), synthesis_box(run), run.grid.nx > 1


def shared_stencil_nbytes(run: MannRun) -> int:
    """Bytes [B] of the unit stencil of ``run`` (a sweep's worker holds it besides the run's scaled one)."""
    return stencil_nbytes(synthesis_box(run), _evolving(run), "unit")


def _evolving(run: MannRun) -> bool:
    """Whether the run makes several snapshots from one stencil."""
    return run.params.evo_time_s is not None and run.grid.nx > 1


def memory_estimate_bytes(run: MannRun, threads: int, with_stencil: bool = True) -> int:
    """Bytes [B] a run allocates: stencil (unless given), snapshot generator (MannSnapshots.bytes_needed), output
    plane and store buffers. A single snapshot computes its stencil on demand (run_mann)."""
    g, evolving = run.grid, _evolving(run)
    on_demand = with_stencil and not evolving
    need = MannSnapshots.bytes_needed(synthesis_box(run), g.ny, g.nz, g.nx if evolving else 1, threads, 2, on_demand)
    need += 2 * g.nt * g.ny * g.nz * 4  # the output plane and the store's encoding buffers
    if with_stencil and evolving:
        need += stencil_nbytes(synthesis_box(run), evolving) + _BUILD_SCRATCH
    return need


def describe(run: MannRun, out: str | Path, threads: int, with_stencil: bool = True) -> list[str]:
    """Lines saying what a run will generate (grid, synthesis box, memory, output path)."""
    g, b, p = run.grid, synthesis_box(run), run.params
    evo = "frozen" if p.evo_time_s is None else f"gamma = {p.evo_time_s:g} s"
    return [
        f"Mann space-time field: L = {p.length_scale_m:g} m, Gamma = {p.gamma:g}, {evo}, lifetime {p.lifetime}, "
        f"ae = {p.ae:.4g} m^(4/3)/s^2 ({run.ae_from}), U = {run.U_m_s:g} m/s, seed {run.seed}",
        f"grid: {g.nt} x {g.nx} x {g.ny} x {g.nz} (t, x, y, z), dt = {g.dt_s:g} s (dx = {b.dx_m:g} m), "
        f"dy = {g.dy_m:g} m, dz = {g.dz_m:g} m, planes x = {', '.join(f'{x:g}' for x in g.x_m)} m",
        f"synthesis box: {b.nt} x {b.nyp} x {b.nzp} (pad-yz {run.pad_yz}), "
        f"{b.nt * b.dx_m:g} x {b.nyp * b.dy_m:g} x {b.nzp * b.dz_m:g} m",
        f"memory: about {format_bytes(memory_estimate_bytes(run, threads, with_stencil))} in one pass; "
        f"output: {out} ({format_bytes(3 * g.nbytes_per_component())} float32, uncompressed)",
    ]


def progress_bar(desc: str, total: int, unit: str, show: bool):
    """A progress bar on standard error (only on a terminal and when ``show``)."""
    return tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, disable=not (show and sys.stderr.isatty()))


def _touch_while_loading_kernels(gen: MannSnapshots, output: bool = True) -> None:
    """Touch a single snapshot's fresh buffers (spectra in a thread, the output plane here unless ``output=False``)
    while numba's first call loads the compiled noise holding the GIL; returns when all is touched."""
    spectra, plane = gen.single_buffers(output)
    with ThreadPoolExecutor(1) as pool:
        touched = pool.submit(spectra.fill, 0)
        complex_normal(0, 0, 0, np.empty(1, dtype=np.complex64))  # the stream is discarded: only the load counts
        if plane is not None:
            plane.fill(0.0)
        touched.result()


def _checked_stencil(run: MannRun, stencil: MannStencil | None) -> None:
    """Refuse a given stencil built for another run than ``run`` (a unit stencil: for another but in ae)."""
    if stencil is None:
        return
    params = run.params.with_ae(1.0) if stencil.energy == "unit" else run.params
    if stencil.params != params or stencil.box != synthesis_box(run) or stencil.slab_range != (0, stencil.box.nk1):
        raise ParameterError("the given stencil was built for other parameters or another grid than this run")
    if stencil.inv_tau is None and _evolving(run):
        raise ParameterError("the given stencil was built for one plane (evolving=False); this run evolves planes")


def _run_stencil(run: MannRun, stencil: MannStencil | None, cache_dir) -> MannStencil:
    """The stencil ``run`` is made with: ``stencil`` scaled to the run's ae, else one snapshot's computed on
    demand, else built (or read from ``cache_dir``)."""
    if stencil is not None:
        return stencil.scaled(run.params)
    if cache_dir is None and not _evolving(run):
        return build_stencil(run.params, synthesis_box(run), storage="on_demand")
    return build_mann_stencil(run, cache_dir)


def _generate(writer, run: MannRun, stencil: MannStencil, threads: int, progress: bool, in_place: bool = False,
              gen: MannSnapshots | None = None) -> dict:  # fmt: skip
    """Every plane of ``run`` into ``writer`` (StoreWriter or MemoryWriter); returns {component: [sum, sum of
    squares]}. ``in_place``: planes transformed straight into the MemoryWriter's field; ``gen``: a generator on
    ``stencil`` kept from an earlier seed."""
    g = run.grid
    sums = {c: [0.0, 0.0] for c in COMPONENTS}
    gen = gen or MannSnapshots(stencil, g.ny, g.nz, threads, buffers=2)
    if stencil.coef is None:  # one snapshot, its stencil computed on demand: no compiled code has run yet
        _touch_while_loading_kernels(gen, output=not in_place)
    # One write in flight while the generator computes the next item (it alternates two buffers);
    # leaving the pool waits for that write, so an exception never races the writer's clean-up.
    with progress_bar("mann", g.nx, "plane", progress) as bar, ThreadPoolExecutor(1) as background:
        pending = None

        def write_and_sum(comp, ix, field):  # in the background, with the next item's synthesis
            total, squares = writer.write(comp, ix, field, squares=True)  # the sums of its finiteness check
            sums[comp][0] += total
            sums[comp][1] += squares

        target = (lambda ix, c: writer.plane(COMPONENTS[c], ix)) if in_place else None
        for done, (ix, comp, field) in enumerate(gen.generate(run.seed, run.plane_times_s(), target=target), start=1):
            if pending is not None:
                pending.result()
            pending = background.submit(write_and_sum, comp, ix, field)
            if done % 3 == 0:
                bar.update(1)
        if pending is not None:
            pending.result()
    return sums


def field_summary(path, t_start: float, sums: dict, grid, **extra) -> dict:
    """A run's summary: path, seconds, ``extra`` and sigma_/mean_ u/v/w [m/s] from {component: [sum, sum of squares]}."""
    n = grid.nt * grid.nx * grid.ny * grid.nz
    summary = {"path": None if path is None else str(path), "seconds": time.perf_counter() - t_start, **extra}
    for c, (s1, s2) in sums.items():
        mean = s1 / n
        summary[f"sigma_{c}"] = math.sqrt(max(s2 / n - mean * mean, 0.0))
        summary[f"mean_{c}"] = mean
    return summary


def _require_memory(run: MannRun, threads: int, stencil, field_bytes: int = 0) -> None:
    g, box = run.grid, synthesis_box(run)
    require_memory(
        memory_estimate_bytes(run, threads, with_stencil=stencil is None) + field_bytes,
        f"the Mann run ({g.nt} x {g.ny} x {g.nz}, synthesis box {box.nt} x {box.nyp} x {box.nzp})"
        + (" and its field in memory" if field_bytes else ""),
        "lower `nt`, `ny`/`nz` or `pad_yz`",
    )


def run_mann(run: MannRun, out: str | Path, *, overwrite: bool = False, chunk_t: int | None = None,
             progress: bool = False, stencil: MannStencil | None = None, threads: int | None = None,
             cache_dir: str | Path | None = None) -> dict:  # fmt: skip
    """Generate ``run`` into a new store at ``out``; return {path, sigma_u/v/w [m/s], seconds, ...}. Memory is checked
    before anything is allocated; an exception (or Ctrl-C) leaves no store. ``stencil`` (build_mann_stencil of a run
    differing at most in seed; a unit stencil: also in ae) skips its computation; ``threads`` (default os.cpu_count())
    does not change the field."""
    t_start = time.perf_counter()
    gen_threads = default_threads(threads)
    _checked_stencil(run, stencil)
    _require_memory(run, gen_threads, stencil)
    path = Path(out)
    with create_store(path, run.grid, run.to_attrs(), chunk_t=chunk_t, overwrite=overwrite) as writer:
        sums = _generate(writer, run, _run_stencil(run, stencil, cache_dir), gen_threads, progress)
    return field_summary(path, t_start, sums, run.grid)


def mann_in_memory(run: MannRun, *, progress: bool = False, stencil: MannStencil | None = None,
                   threads: int | None = None, cache_dir: str | Path | None = None,
                   snapshots: MannSnapshots | None = None):  # fmt: skip
    """The field of ``run`` in memory as run_mann's store would open (but ``created_utc``): (xarray.Dataset,
    summary with path None); arguments as run_mann's, ``snapshots`` a MannSnapshots(..., buffers=2) of an earlier
    seed. ParameterError when the run and the field's 3 float32 components exceed the available memory."""
    t_start = time.perf_counter()
    gen_threads = default_threads(threads)
    _checked_stencil(run, stencil)
    if snapshots is not None and (stencil is None or snapshots.stencil is not stencil):
        raise ValueError("`snapshots` must be a generator on the given stencil")
    if snapshots is None:
        _require_memory(run, gen_threads, stencil, 3 * run.grid.nbytes_per_component())
    else:  # the run's buffers are held already: the field
        require_memory(3 * run.grid.nbytes_per_component(), "the Mann field in memory", "lower `nt` or `ny`/`nz`")
    with MemoryWriter(run.grid, run.to_attrs()) as writer:
        sums = _generate(writer, run, _run_stencil(run, stencil, cache_dir), gen_threads, progress, in_place=True,
                         gen=snapshots)  # fmt: skip
    return writer.dataset, field_summary(None, t_start, sums, run.grid)


def _out_of_core(run: MannRun, threads: int | None, memory_bytes: int | None) -> bool:
    """Whether a Mann run exceeds its memory budget (then mann_outofcore makes it)."""
    if memory_bytes is None:
        return False
    from turbgen.runs.mann_outofcore import fits_in_memory

    return not fits_in_memory(run, memory_bytes, threads or os.cpu_count() or 1)


def _run(run: MannRun, out, *, overwrite=False, chunk_t=None, threads=None, memory_bytes=None, shared=None):
    if _out_of_core(run, threads, memory_bytes):
        from turbgen.runs.mann_outofcore import run_mann_outofcore

        return run_mann_outofcore(run, out, memory_bytes=memory_bytes, overwrite=overwrite, chunk_t=chunk_t,
                                  threads=threads)
    return run_mann(run, out, overwrite=overwrite, chunk_t=chunk_t, stencil=shared, threads=threads)


def _shared(run: MannRun, threads: int | None, memory_bytes: int | None):
    if _out_of_core(run, threads, memory_bytes):
        return None
    return functools.partial(build_mann_stencil, energy="unit")  # picklable: a sweep's workers build it


MODEL = Model("mann", MannRun, _run, memory_estimate_bytes, lambda run: memory_estimate_bytes(run, 1),
              "`nt`, `ny`/`nz` or `pad_yz`", _shared, shared_stencil_key, shared_stencil_nbytes, out_of_core=True)
