"""Out-of-core Mann runs: a field whose snapshot does not fit in memory, in two passes through scratch files.

Pass 1, per part of S k1 slabs (a multiple of the synthesis batch: every number as in memory): the part's stencil,
its snapshots in time order, cropped spectra to the spectrum file (snapshot, component, part, point, slab).
Pass 2, per snapshot, component and block of (y, z) points: read back, transformed along k1 (PencilTransform) into
the output plane (in memory, else a plane file), written in time chunks. Bit for bit run_mann's field.

S, the block sizes and the time chunk follow ``memory_bytes``. Scratch files live in ``.NAME.scratch-PID-XXXX``
next to the output: removed at the end, on any exception, or by the next run once their process is dead. With a
dask ``client`` the parts and blocks are its tasks (the scratch directory on a shared filesystem)."""

from __future__ import annotations

import os
from contextlib import nullcontext
import re
import shutil
import time
from pathlib import Path

import numpy as np

from turbgen import fft
from turbgen.atomic import temp_name, temp_prefix
from turbgen.errors import ParameterError
from turbgen.oscalls import resident_bytes
from turbgen.resources import default_threads, format_bytes, require_disk
from turbgen.runs.mann import field_summary, memory_estimate_bytes, progress_bar
from turbgen.runs.scratch import ScratchFile
from turbgen.spec.mann import MannRun
from turbgen.store import create_store
from turbgen.store.layout import default_chunk_t
from turbgen.store.temporaries import pid_alive
from turbgen.synthesis.mann_spacetime import COMPONENTS, ROW_BLOCK, SLAB_BATCH, MannSnapshots, PencilTransform
from turbgen.synthesis.mann_cells import axis_cells
from turbgen.synthesis.mann_stencil import build_stencil, synthesis_box

BASE_BYTES = 250 * 2**20  # the interpreter with turbgen, numpy, scipy, zarr, pyfftw loaded (165-197 MiB) + slack
# what a run allocates after it is planned besides the planned arrays: the axis cells' temporaries (~30 MiB), FFTW
# plans, zarr's buffers and the compiled kernels' library pages (libllvmlite.so: 40-85 MiB resident)
LATE_BYTES = 96 * 2**20
# what a LocalCluster adds to the process that starts it: distributed, its scheduler, the resource tracker (~30 MiB)
LOCAL_CLUSTER_BYTES = 32 * 2**20
# what a fresh worker process adds to this module's imports before its first task ends: numba's LLVM (~52 MiB), the
# lifetime tables, distributed's worker (~20 MiB)
WORKER_LOADS_BYTES = 96 * 2**20
_C64, _F32 = 8, 4
SCRATCH_MARK = ".scratch-"  # scratch directories: .NAME.scratch-PID-XXXXXXXX next to the output
_HINT = "raise `memory`, or lower `nt`, `ny`/`nz` or `pad_yz`"


def worker_base_bytes() -> int:
    """What a fresh worker process holds besides a task's planned arrays [B]: this process's resident memory
    after the imports plus WORKER_LOADS_BYTES and LATE_BYTES; at least BASE_BYTES."""
    if _IMPORTED_RESIDENT is None:
        return BASE_BYTES
    return max(BASE_BYTES, _IMPORTED_RESIDENT + WORKER_LOADS_BYTES + LATE_BYTES)


def base_bytes() -> int:
    """Memory [B] a budget leaves besides a run's planned arrays: BASE_BYTES, or what is resident now plus LATE_BYTES if
    more (computing ae from sigma_u first leaves ~70-125 MiB more resident; a budget bounds VmHWM)."""
    resident = resident_bytes()
    return BASE_BYTES if resident is None else max(BASE_BYTES, resident + LATE_BYTES)


def remove_stale_scratch(out: str | Path) -> list[Path]:
    """Remove scratch directories of ``out`` left by dead processes (kill -9); return what was removed."""
    out = Path(out).expanduser().absolute()
    removed = []
    pattern = re.compile(re.escape(temp_prefix(out, SCRATCH_MARK)) + r"(\d+)-[0-9a-f]+$")
    if not out.parent.is_dir():
        return removed
    for p in out.parent.iterdir():
        m = pattern.match(p.name)
        if m and not pid_alive(int(m.group(1))):
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
    return removed


class OutOfCorePlan:
    """Sizes of an out-of-core run under a memory budget [bytes] (see module docstring)."""

    def __init__(self, run: MannRun, memory_bytes: int, threads: int, chunk_t: int | None = None, *,
                 slabs_per_part: int | None = None, block_points: int | None = None,
                 plane_in_memory: bool | None = None, base: int | None = None, per_worker: bool = False):  # fmt: skip
        """Sizes from the budget; ``slabs_per_part`` (multiple of SLAB_BATCH), ``block_points`` (multiple of
        ROW_BLOCK) and ``plane_in_memory`` override them (tests). ``base``: what the process holds besides the planned
        arrays [B] (default :func:`base_bytes`). ``per_worker``: the budget is each worker's of a dask cluster
        (plan_for_budget). ``minimum_bytes``: the smallest budget with one part."""
        g, box = run.grid, synthesis_box(run)
        self.run, self.memory_bytes, self.threads = run, int(memory_bytes), threads
        self.per_worker = per_worker
        self.evolving = run.params.evo_time_s is not None and g.nx > 1
        self.n_snapshots = g.nx if self.evolving else 1
        self.points = g.ny * g.nz
        align = SLAB_BATCH
        slab = box.nyp * box.nzp
        half = box.nk2_half * box.nzp
        scratch = threads * SLAB_BATCH * slab * (2 * 3 * 8 + 2 * 8 + 8 * 4)  # MannSnapshots' per-thread buffers
        building = (os.cpu_count() or 1) * (1 << 16) * 8 * 16  # float64 temporaries of the stencil batches
        per_slab = (
            (5 if self.evolving else 4) * half * _F32  # stencil part
            + (3 * slab * _C64 if self.evolving else 0)  # OU state
            + 4 * self.points * _C64  # cropped spectra, and one component's contiguous copy for the scratch write
        )
        # 3/4 of what is left: numpy temporaries, allocator slack (measured: the peak stays below the budget)
        base = base_bytes() if base is None else base
        free = (self.memory_bytes - base - scratch - building) * 3 // 4
        self.minimum_bytes = base + scratch + building + per_slab * align * 4 // 3
        self.slabs_per_part = (free // (per_slab * align)) * align if free > 0 else 0
        if self.slabs_per_part < align:
            # without `ae` its sigma_u quadrature ran in this process first and left more memory resident (README)
            given = run.ae_from == "ae"
            raise ParameterError(
                f"the out-of-core Mann run needs at least {format_bytes(self.minimum_bytes)} of memory "
                f"(got a budget of {format_bytes(self.memory_bytes)}); {_HINT}"
                + ("" if given else f", or give `ae` (here {run.params.ae:.4g}: computing it from sigma_u first leaves "
                                    "more memory resident)")
            )
        self.slabs_per_part = min(self.slabs_per_part, -(-box.nk1 // align) * align)
        if slabs_per_part is not None:
            if slabs_per_part < 1 or slabs_per_part % align:
                raise ValueError(f"slabs_per_part must be a positive multiple of {align}")
            self.slabs_per_part = slabs_per_part
        self.n_parts = -(-box.nk1 // self.slabs_per_part)
        # pass 2: the plane (and a copy) in memory if they fit a quarter of the budget, else a plane scratch file
        plane = g.nt * self.points * _F32
        pass2 = self.memory_bytes - base
        self.plane_in_memory = 2 * plane <= pass2 // 4 if plane_in_memory is None else plane_in_memory
        # points read back per block: spectra (block, nk1) complex64 twice + their transform, within an eighth
        per_point = 2 * self.n_parts * self.slabs_per_part * _C64 + g.nt * _F32
        block = max(ROW_BLOCK, (pass2 // 8 // per_point) // ROW_BLOCK * ROW_BLOCK)
        self.block_points = min(block, -(-self.points // ROW_BLOCK) * ROW_BLOCK)
        if block_points is not None:
            if block_points < 1 or block_points % ROW_BLOCK:
                raise ValueError(f"block_points must be a positive multiple of {ROW_BLOCK}")
            self.block_points = block_points
        # the store's time chunk: as by default, but a chunk and its encoding buffers within an eighth
        fit = max(1, (pass2 // 8) // (4 * self.points * _F32))
        self.chunk_t = chunk_t if chunk_t is not None else min(default_chunk_t(g.nt), fit)

    def scratch_bytes(self) -> int:
        """Disk bytes of the scratch files (spectra, and the plane file when the plane is not held in memory)."""
        g = self.run.grid
        spectra = self.n_snapshots * 3 * self.n_parts * self.points * self.slabs_per_part * _C64
        n_blocks = -(-self.points // self.block_points)
        plane = 0 if self.plane_in_memory else n_blocks * g.nt * self.block_points * _F32
        return spectra + plane

    def describe(self) -> str:
        """One line: parts, blocks, plane handling, scratch size."""
        where = "in memory" if self.plane_in_memory else "via a plane scratch file"
        return (
            f"out-of-core: budget {format_bytes(self.memory_bytes)}{' per worker' if self.per_worker else ''}, "
            f"{self.n_parts} part(s) of "
            f"{self.slabs_per_part} k1 slabs, blocks of {self.block_points} (y, z) points, planes {where}, "
            f"store time chunk {self.chunk_t}, scratch {format_bytes(self.scratch_bytes())}"
        )


def least_budget_bytes(run: MannRun, chunk_t: int | None = None) -> int:
    """A lower bound [B] of any process's budget for ``run``: in memory or out of core with one thread, on
    the smallest base (BASE_BYTES). A sweep refuses a budget below it before it starts."""
    base = min(BASE_BYTES, base_bytes())
    return min(memory_estimate_bytes(run, 1) + base, OutOfCorePlan(run, 2**62, 1, chunk_t, base=base).minimum_bytes)


def fits_in_memory(run: MannRun, memory_bytes: int | None, threads: int, with_stencil: bool = True) -> bool:
    """Whether ``run`` fits ``memory_bytes`` in one pass (memory_estimate_bytes + :func:`base_bytes`)."""
    return memory_bytes is None or memory_estimate_bytes(run, threads, with_stencil) + base_bytes() <= memory_bytes


def plan_for_budget(run: MannRun, memory_bytes: int | None, threads: int, chunk_t: int | None = None,
                    scheduler: str | None = None, with_stencil: bool = True) -> OutOfCorePlan | None:
    """The out-of-core plan of ``run`` if it does not fit ``memory_bytes`` in memory, else None; ``scheduler`` None:
    both passes here on ``threads`` threads; "local": a LocalCluster of ``threads`` single-threaded workers sharing the
    budget with this process; an address: the budget per worker. ``with_stencil``: the in-memory run would build its
    stencil. ParameterError if too small even out of core."""
    if fits_in_memory(run, memory_bytes, threads, with_stencil):
        return None
    if scheduler != "local":
        return OutOfCorePlan(run, memory_bytes, threads, chunk_t, per_worker=scheduler is not None)
    # this process (what it holds, the cluster's own share) and the workers, fresh processes
    here, worker_base = base_bytes() + LOCAL_CLUSTER_BYTES, worker_base_bytes()
    per_worker = OutOfCorePlan(run, 2**62, 1, chunk_t, base=worker_base).minimum_bytes
    if memory_bytes - here < threads * per_worker:
        raise ParameterError(
            f"the out-of-core Mann run on a local cluster of {threads} workers needs at least "
            f"{format_bytes(here + threads * per_worker)} of memory (this process {format_bytes(here)}, each worker "
            f"{format_bytes(per_worker)}; got a budget of {format_bytes(memory_bytes)}); raise `memory`, use fewer "
            "`threads` (workers), or lower `nt`, `ny`/`nz` or `pad_yz`"
        )
    return OutOfCorePlan(run, (memory_bytes - here) // threads, 1, chunk_t, base=worker_base, per_worker=True)


def local_cluster(workers: int):
    """A quiet loopback LocalCluster of ``workers`` single-threaded processes (plan_for_budget's "local")."""
    from turbgen.runs.local_cluster import loopback_cluster

    return loopback_cluster(workers, 1, processes=True)


class _File(ScratchFile):
    """The scratch file at ``path``; ``nbytes``: create it sparse."""

    def __init__(self, path: Path, nbytes: int | None = None):
        if nbytes is None:
            super().__init__(os.open(path, os.O_RDWR))
        else:
            super().__init__(os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o600))
            os.ftruncate(self.fd, max(1, nbytes))


def run_mann_outofcore(run: MannRun, out: str | Path, *, memory_bytes: int, overwrite: bool = False,
                       chunk_t: int | None = None, progress: bool = False, threads: int | None = None,
                       plan: OutOfCorePlan | None = None, client=None) -> dict:  # fmt: skip
    """Generate ``run`` (run_mann's field bit for bit) into a new store at ``out`` within ``memory_bytes``; return
    {path, sigma_*, mean_*, seconds, plan}. Disk is checked first; an exception leaves no store or scratch.
    ``client``: a dask Client running the passes' tasks (``memory_bytes``, ``threads`` per task)."""
    t_start = time.perf_counter()
    threads = default_threads(threads)
    backend = fft.current()
    plan = plan or OutOfCorePlan(run, memory_bytes, threads, chunk_t)
    plan.plane_in_memory = plan.plane_in_memory and client is None  # workers hand planes over through the plane file
    g = run.grid
    path = Path(out).expanduser().absolute()
    remove_stale_scratch(path)
    require_disk(path.parent, 3 * g.nbytes_per_component() + plan.scratch_bytes(),
                 "the out-of-core Mann run (store + scratch)", "free disk space or write `out` elsewhere")
    times = np.sort(run.plane_times_s(), kind="stable")[: None if plan.evolving else 1]
    order = [int(i) for i in np.argsort(run.plane_times_s(), kind="stable")]
    sums = {c: [0.0, 0.0] for c in COMPONENTS}
    scratch_dir = temp_name(path, SCRATCH_MARK)
    n_blocks = -(-plan.points // plan.block_points)
    with create_store(path, g, run.to_attrs(), chunk_t=plan.chunk_t, overwrite=overwrite) as writer:
        scratch_dir.mkdir()
        try:
            spectra_path, plane_path = scratch_dir / "spectra", scratch_dir / "plane"
            _File(spectra_path, plan.n_snapshots * 3 * plan.n_parts * plan.points * plan.slabs_per_part * _C64).close()
            if not plan.plane_in_memory:
                _File(plane_path, n_blocks * g.nt * plan.block_points * _F32).close()
            cells = axis_cells(run.params, synthesis_box(run))
            with progress_bar("mann pass 1", plan.n_parts, "part", progress) as bar:
                args = (run, plan, str(spectra_path), cells, times, threads, backend)
                _map(client, lambda part: pass1_part(*args, part), range(plan.n_parts), bar)
            del cells
            plane = np.empty((g.nt, plan.points), np.float32) if plan.plane_in_memory else None  # after pass 1
            with progress_bar("mann pass 2", 3 * plan.n_snapshots, "it", progress) as bar:
                for m in range(plan.n_snapshots):
                    targets = [order[m]] if plan.evolving else order  # frozen: the one snapshot is every plane
                    for c, comp in enumerate(COMPONENTS):
                        if plane is not None:
                            pass2_blocks(run, plan, str(spectra_path), None, m, c, range(n_blocks), backend, plane)
                        else:
                            blocks = [range(b, b + 1) for b in range(n_blocks)]
                            args2 = (run, plan, str(spectra_path), str(plane_path), m, c)
                            _map(client, lambda bl: pass2_blocks(*args2, bl, backend), blocks, None)
                        with _File(plane_path) if plane is None else nullcontext() as plane_file:
                            for ix in targets:
                                _write_plane(writer, comp, ix, plane, plane_file, plan, g, sums)
                        bar.update(1)
        finally:
            shutil.rmtree(scratch_dir, ignore_errors=True)
    return field_summary(path, t_start, sums, g, plan=plan.describe())


def _map(client, fn, items, bar) -> None:
    """fn over items: here, or as tasks of ``client`` (results are None; an exception is raised here)."""
    if client is None:
        for item in items:
            fn(item)
            if bar is not None:
                bar.update(1)
        return
    from distributed import as_completed

    futures = [client.submit(fn, item, pure=False) for item in items]
    try:
        for fut in as_completed(futures):
            fut.result()
            if bar is not None:
                bar.update(1)
    finally:
        client.cancel(futures)


def _spectra_offset(plan: OutOfCorePlan, m: int, c: int, part: int, point: int = 0) -> int:
    return (((m * 3 + c) * plan.n_parts + part) * plan.points + point) * plan.slabs_per_part * _C64


def pass1_part(run: MannRun, plan: OutOfCorePlan, spectra_path: str, cells, times, threads: int, fft_backend: str,
               part: int) -> None:  # fmt: skip
    """Pass 1 for one part of k1 slabs: its stencil and snapshots, cropped spectra to the scratch file."""
    box, g = synthesis_box(run), run.grid
    S = plan.slabs_per_part
    first, end = part * S, min((part + 1) * S, box.nk1)
    stencil = build_stencil(run.params, box, evolving=plan.evolving, slabs=(first, end), cells=cells)
    gen = MannSnapshots(stencil, g.ny, g.nz, threads, fft_backend=fft_backend)
    with _File(Path(spectra_path)) as spectra_file:
        for m, spectra in gen.spectra(run.seed, times):
            for c in range(3):
                block = spectra[c]  # (points, end - first); the last part's rows padded to S slabs: one write each
                block = block if end - first == S else np.pad(block, ((0, 0), (0, S - (end - first))))
                spectra_file.write(_spectra_offset(plan, m, c, part), block)


def pass2_blocks(run, plan: OutOfCorePlan, spectra_path: str, plane_path: str | None, m: int, c: int, blocks,
                 fft_backend: str, plane: np.ndarray | None = None) -> None:  # fmt: skip
    """Pass 2 for blocks of (y, z) points of snapshot m, component c: read back, transformed along k1, into
    ``plane`` (nt, points) or the plane scratch file (block, t, point)."""
    g, box = run.grid, synthesis_box(run)
    S, P, B = plan.slabs_per_part, plan.points, plan.block_points
    transform = PencilTransform(g.nt, P, fft_backend)
    parts = np.empty((plan.n_parts, B, S), np.complex64)
    spectra = np.empty((B, plan.n_parts * S), np.complex64)
    block_out = np.empty((g.nt, B), np.float32) if plane is None else None
    with _File(Path(spectra_path)) as spectra_file, (_File(Path(plane_path)) if plane is None else nullcontext()) as pf:
        for b in blocks:
            p0, p1 = b * B, min((b + 1) * B, P)
            n = p1 - p0
            for part in range(plan.n_parts):
                spectra_file.read(_spectra_offset(plan, m, c, part, p0), parts[part, :n])
            np.copyto(spectra[:n].reshape(n, plan.n_parts, S), parts[:, :n].transpose(1, 0, 2))
            dest = plane[:, p0:p1] if plane is not None else block_out[:, :n]
            for r0 in range(0, n, ROW_BLOCK):
                r1 = min(r0 + ROW_BLOCK, n)
                transform(spectra[r0:r1, : box.nk1], dest[:, r0:r1])
            if pf is not None:
                pf.write(b * g.nt * B * _F32, block_out)


def _write_plane(writer, comp, ix, plane, plane_file, plan, g, sums) -> None:
    """The plane (held, or in the plane file) to the store in time chunks; accumulate its sums."""
    P, B, ct = plan.points, plan.block_points, plan.chunk_t
    for t0 in range(0, g.nt, ct):
        t1 = min(t0 + ct, g.nt)
        if plane is not None:
            chunk = plane[t0:t1]
        else:
            chunk = np.empty((t1 - t0, P), np.float32)
            piece = np.empty((t1 - t0, B), np.float32)
            for b in range(-(-P // B)):
                p0, p1 = b * B, min((b + 1) * B, P)
                plane_file.read((b * g.nt + t0) * B * _F32, piece)
                chunk[:, p0:p1] = piece[:, : p1 - p0]
        total, squares = writer.write(comp, ix, chunk.reshape(t1 - t0, g.ny, g.nz), t0, squares=True)
        sums[comp][0] += total
        sums[comp][1] += squares


# this process's resident memory once the modules above were imported (the model of a fresh worker's, see
# worker_base_bytes); None where /proc does not tell
_IMPORTED_RESIDENT = resident_bytes()
