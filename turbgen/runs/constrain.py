"""Constrained Mann runs: a field conditioned on measured point time series (Hoffman & Ribak 1991).

A sensor at (x, y, z) belongs to the plane at x; its value at time T is the stored sample t = T + x / U (convected
frame, Guo et al. 2023 Sect. 5.1.2), interpolated linearly onto the stored times (missing outside the data's span or
next to a missing value) and bilinearly in (y, z). ``total_wind`` data lose their mean wind first
(turbgen.spec.constraints.sensor_fluctuations).

Pass 1 generates the sample u_s and measures H u_s; S x = d - H u_s - eps_s is solved (turbgen.synthesis.conditioning);
pass 2 generates u_s again (bit-identical) and adds C H^T x while writing (``conditional_mean``: C H^T S^-1 d only).
The store's ``constraints`` attribute records data, geometry, noise, solver report and residual."""

from __future__ import annotations

import math
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.virtual_lidar.sampling import PLANE_TOL_M
from turbgen.resources import default_threads, require_disk, require_memory
from turbgen.runs.correction_scratch import CorrectionScratch
from turbgen.runs.mann import build_mann_stencil, field_summary, memory_estimate_bytes, progress_bar
from turbgen.runs.stencil_cache import cached_system, system_key
from turbgen.spec.constraints import COMPONENTS, PointSeries, check_noise, sensor_fluctuations
from turbgen.spec.mann import MannRun
from turbgen.store import create_store
from turbgen.store.memory import MemoryWriter
from turbgen.synthesis import conditioning as cond
from turbgen.synthesis.mann_spacetime import MannSnapshots
from turbgen.synthesis.mann_stencil import synthesis_box

_NOISE_KEY = 0x636F6E73  # "cons": the stream of the measurement-noise sample eps_s, keyed with the run's seed
# a note when total-wind data blow further than this from the field's x after their declared mean wind [deg]: a 10-min
# mean direction scatters by ~(sigma_v / U) sqrt(2 T_int / T) ~ 1 deg, so this is a frame, not turbulence
OFF_WIND_DEG = 5.0


@dataclass(frozen=True, eq=False)
class PlacedData:
    """Measurements on the run's grid: streams, data (M, nt) [m/s] (NaN: missing), noise sigma (M,) [m/s] and a
    geometry record per stream."""

    streams: cond.Streams
    data: np.ndarray
    noise_m_s: np.ndarray
    geometry: tuple[dict, ...]


def _axis_terms(value: float, coords: np.ndarray, step: float, what: str, where: str) -> list[tuple[int, float]]:
    """(index, weight) of the linear interpolation at ``value`` on the regular ``coords``; refuses outside them."""
    lo, hi = coords[0], coords[-1]
    tol = 1e-9 * max(1.0, abs(step))
    if not lo - tol <= value <= hi + tol:
        raise ParameterError(f"{where}: {what} = {value:g} m is outside the field ({lo:g} .. {hi:g} m)")
    if len(coords) == 1:
        return [(0, 1.0)]
    f = min(max((value - lo) / step, 0.0), len(coords) - 1.0)
    i = min(int(math.floor(f)), len(coords) - 2)
    frac = f - i
    return [(j, w) for j, w in ((i, 1.0 - frac), (i + 1, frac)) if w != 0.0]


def _plane(run: MannRun, x: float, where: str, file_x: float | None = None) -> int:
    """The index of the run's plane at ``x`` [m], else (a replay's sensor turned into the wind's frame) at its file's
    ``file_x``: the Taylor delay stays that of ``x`` (:func:`_on_grid`); ParameterError if neither is a plane."""
    xs = run.grid.x()
    for v in (x,) if file_x is None else (x, file_x):
        i = int(np.argmin(np.abs(xs - v)))
        if abs(xs[i] - v) <= PLANE_TOL_M * max(1.0, abs(v)):
            return i
    planes = ", ".join(f"{v:g}" for v in xs)
    also = "" if file_x is None else f" (turned into the wind's frame; nor is its file's x = {file_x:g} m)"
    raise ParameterError(f"{where}: x = {x:g} m{also} is not a plane of the run (planes: {planes} m); make the field "
                         "with a plane there (`x_m`)")  # fmt: skip


def _on_grid(run: MannRun, t_s: np.ndarray, values: np.ndarray, x: float, where: str) -> np.ndarray:
    """The series interpolated linearly onto the stored times of the plane at x (NaN outside its span or next to a
    missing value); refuses data whose span less its first and last sample interval leaves the record [0, (nt - 1)
    dt] (a first or last sample just outside it, a sensor's Taylor delay, still counts at the record's end)."""
    g = run.grid
    stored = t_s + x / run.U_m_s
    end = (g.nt - 1) * g.dt_s
    inner = stored[[1, -2]] if len(stored) > 1 else stored[[0, 0]]
    if inner[0] < -1e-9 * g.dt_s or inner[1] > end + 1e-9 * g.dt_s:
        raise ParameterError(f"{where}: its samples fall at stored times {stored[0]:g} .. {stored[-1]:g} s "
                             f"(time + x/U), outside the field's record 0 .. {end:g} s")  # fmt: skip
    tn = g.t()
    k = np.clip(np.searchsorted(stored, tn, side="right") - 1, 0, len(stored) - 2)
    frac = (tn - stored[k]) / (stored[k + 1] - stored[k])
    out = values[k] * (1.0 - frac) + values[k + 1] * frac
    exact_left, exact_right = frac == 0.0, frac == 1.0  # a sample on a stored time needs no neighbour
    out[exact_left] = values[k[exact_left]]
    out[exact_right] = values[k[exact_right] + 1]  # the last sample (NaN * 0 of a missing neighbour is NaN)
    out[(tn < stored[0]) | (tn > stored[-1])] = math.nan
    return out


@dataclass(frozen=True, eq=False)
class PlacedStream:
    """One measured series on the grid: ``terms`` (T, 5) rows (component, y index, z index, time shift [steps],
    weight) of plane ``plane``, observed every ``decimation`` steps from ``offset``; ``data`` [m/s] (NaN: missing)."""

    plane: int
    terms: np.ndarray
    decimation: int
    offset: int
    data: np.ndarray
    noise_m_s: float
    geometry: dict


def _point_streams(run: MannRun, f: PointSeries, sigma: float) -> list[PlacedStream]:
    g = run.grid
    out = []
    for s in f.sensors:
        where = f"constraint file {f.source}, {s.name}"
        z = s.z_m if s.z_m is not None else s.height_m - run.hub_height_m
        p = _plane(run, s.x_m, where, s.plane_x_m)
        ty = _axis_terms(s.y_m, g.y(), g.dy_m, "y" if s.plane_x_m is None else "y (turned into the wind's frame)",
                         where)
        tz = _axis_terms(z, g.z(), g.dz_m, "z" if s.z_m is not None else f"z (height {s.height_m:g} m less the hub "
                         f"height {run.hub_height_m:g} m, `hub_height_m`)", where)
        series, shift = sensor_fluctuations(f, s, run.U_m_s, run.hub_height_m)
        off = {"direction_deg": math.degrees(math.atan2(np.nanmean(series["v"]), shift + np.nanmean(series["u"])))
               } if f.total_wind and {"u", "v"} <= series.keys() else {}  # what the declared mean wind left
        for comp, values in series.items():
            c = COMPONENTS.index(comp)
            on_grid = _on_grid(run, f.time_s, values, s.x_m, where)
            if not np.isfinite(on_grid).any():
                raise ParameterError(f"{where}: {comp} has no value at the field's time steps")
            terms = np.array([(c, iy, iz, 0, wy * wz) for iy, wy in ty for iz, wz in tz], dtype=float)
            name = f"{Path(f.source).name}:{s.name}:{comp}"
            out.append(PlacedStream(p, terms, 1, 0, on_grid, sigma, {
                "name": name, "kind": "point", "component": comp, "x_m": s.x_m, "y_m": s.y_m, "z_m": z, "plane": p,
                "noise_m_s": sigma, "mean_wind_subtracted_m_s": shift if comp == "u" else 0.0,
                "mean_wind": f.mean_wind.describe() if f.total_wind else "", **(off if comp == "u" else {})}))
    return out


def combine_streams(placed: list[PlacedStream], nt: int) -> PlacedData:
    """One Streams of common decimation Q = lcm of the streams' (dividing nt): a stream observed every q steps
    becomes Q/q streams observed every Q steps from o + r q."""
    big_q = math.lcm(*(s.decimation for s in placed))
    if nt % big_q:
        raise ParameterError(f"the measurements' sampling periods (every {big_q} time steps in common) do not divide "
                             f"the record of {nt} steps: make the field with `nt` a multiple of {big_q}")  # fmt: skip
    planes, terms, offsets, data, noise, geometry, names = [], [], [], [], [], [], []
    for s in placed:
        parts = big_q // s.decimation
        for r in range(parts):
            a = len(planes)
            planes.append(s.plane)
            offsets.append(s.offset + r * s.decimation)
            terms.append(np.column_stack([np.full(len(s.terms), a), s.terms]))
            data.append(s.data[r::parts])
            noise.append(s.noise_m_s)
            names.append(s.geometry["name"] if parts == 1 else f"{s.geometry['name']}[{r}/{parts}]")
            geometry.append(s.geometry if parts == 1 else {**s.geometry, "name": names[-1]})
    t = np.concatenate(terms)
    as_int = [t[:, k].astype(np.int64) for k in range(5)]
    streams = cond.Streams(np.array(planes, dtype=np.int64), as_int[0], as_int[1], as_int[2], as_int[3], t[:, 5],
                           tuple(names), term_shift=as_int[4], decimation=big_q, offset=np.array(offsets, np.int64))
    return PlacedData(streams, np.array(data), np.array(noise), tuple(geometry))


def place(run: MannRun, files: list, noise_m_s: float | None = None) -> PlacedData:
    """The streams and data of ``files`` (PointSeries or LidarData) on the grid of ``run``; ``noise_m_s`` (>= 0)
    replaces every file's own (default: the file's, else 0)."""
    return combine_streams(placed_streams(run, files, noise_m_s), run.grid.nt)


def placed_streams(run, files: list, noise_m_s: float | None = None) -> list[PlacedStream]:
    """Every series of ``files`` on the grid of ``run`` (MannRun or KaimalRun), in file order, not yet combined."""
    from turbgen.runs.constrain_lidar import lidar_streams

    noise_m_s = check_noise(noise_m_s)
    placed = []
    for f in files:
        if isinstance(f, PointSeries):
            placed += _point_streams(run, f, noise_m_s if noise_m_s is not None else (f.noise_m_s or 0.0))
        else:
            placed += lidar_streams(run, f, 0.0 if noise_m_s is None else noise_m_s)
    return placed


def measurement_noise(run: MannRun, placed: PlacedData) -> np.ndarray:
    """eps_s ~ N(0, R) (M, nt), from its own stream keyed by the run's seed (the same on every machine)."""
    rng = np.random.Generator(np.random.SFC64(np.random.SeedSequence((run.seed, _NOISE_KEY))))
    return rng.standard_normal(placed.data.shape) * placed.noise_m_s[:, None]


def stream_system(run: MannRun, stencil, placed: PlacedData, threads: int | None = None,
                  progress: bool = False, cache_dir=None) -> np.ndarray:  # fmt: skip
    """The per-frequency matrices of S = H C H^T + R (conditioning.stream_covariance), H C H^T read from or
    kept in the stencil cache ``cache_dir`` (the same bits). ParameterError for dependent zero-noise measurements."""
    streams, times = placed.streams, run.plane_times_s()

    def compute() -> np.ndarray:
        with progress_bar("system", stencil.box.nk1, "slab", progress) as bar:
            return cond.stream_covariance(stencil, streams, times, np.zeros(streams.n_streams),
                                          default_threads(threads), bar.update)  # fmt: skip

    if cache_dir is None:
        cov = compute()
    else:
        arrays = {name: getattr(streams, name) for name in ("plane", "term_stream", "term_component", "term_iy",
                                                              "term_iz", "term_weight", "term_shift", "offset")}
        arrays["decimation"] = np.array(streams.decimation)
        key = system_key(run.params, stencil.box, stencil.inv_tau is not None, times, arrays)
        shape = (stencil.box.nt // streams.decimation, streams.n_streams, streams.n_streams)
        cov = cached_system(cache_dir, key, shape, compute)
    m = np.arange(streams.n_streams)
    cov[:, m, m] += placed.noise_m_s**2
    if np.any(placed.noise_m_s == 0):
        cond.check_singular(cov, streams.names)
    return cov


def solve_constraints(cov: np.ndarray, placed: PlacedData, measured: np.ndarray | None,
                      eps: np.ndarray | None) -> tuple[np.ndarray, cond.SolveReport]:  # fmt: skip
    """x = S^-1 (d - H u_s - eps_s) (``measured`` None: S^-1 d, the conditional mean), (M, nt), zero where missing."""
    observed = np.isfinite(placed.data)
    r = placed.data if measured is None else placed.data - measured - eps
    return cond.solve(cov, np.where(observed, r, 0.0), observed)


def unconstrained_measurement(run: MannRun, stencil, placed: PlacedData, threads: int,
                               progress: bool = False) -> np.ndarray:  # fmt: skip
    """Pass 1: H u_s of the run's unconstrained sample, measured on the snapshots' spectra
    before their transform along time (only the measured points are kept)."""
    g = run.grid
    times = run.plane_times_s()
    order = [int(i) for i in np.argsort(times, kind="stable")]
    frozen = run.params.evo_time_s is None
    points = cond.measured_points(placed.streams, g.nz)
    gen = MannSnapshots(stencil, g.ny, g.nz, threads, points=points)
    spec = np.zeros((placed.streams.n_streams, g.nt // 2 + 1), complex)

    def measure(m: int, spectra: np.ndarray) -> None:
        for ix in order if frozen else [order[m]]:  # frozen: the one snapshot is every plane
            cond.measure_spectra(placed.streams, ix, spectra, g.nz, g.nt, spec, points)
            bar.update(1)

    # each snapshot measured in a thread while the next is made (the generator's two alternating point buffers)
    with progress_bar("pass 1", g.nx, "plane", progress) as bar, ThreadPoolExecutor(1) as measurer:
        pending = None
        for m, spectra in gen.spectra(run.seed, times):
            if pending is not None:
                pending.result()
            pending = measurer.submit(measure, m, spectra)
        pending.result()
    return cond.spectra_samples(placed.streams, spec, g.nt)


def conditioned_planes(run: MannRun, stencil, placed: PlacedData, cov: np.ndarray, scratch_dir: Path, *,
                       conditional_mean: bool = False, threads: int | None = None,
                       progress: bool = False):  # fmt: skip
    """(solver report, iterator of (plane index, component, field (nt, ny, nz) float32 [m/s])) of ``run``
    conditioned: pass 1 runs here, the iterator is pass 2 (its correction read from a scratch file in
    ``scratch_dir``); two buffers alternate (an array is valid until the item after next)."""
    g = run.grid
    gen = MannSnapshots(stencil, g.ny, g.nz, default_threads(threads), buffers=2)  # write_planes' background writes
    measured = eps = None
    if not conditional_mean:
        measured = unconstrained_measurement(run, stencil, placed, gen.threads, progress)
        eps = measurement_noise(run, placed)
    x, report = solve_constraints(cov, placed, measured, eps)
    frozen = stencil.inv_tau is None  # every plane is the same snapshot, and so is its correction
    wanted = [0] if frozen else list(range(g.nx))
    box = stencil.box

    def planes():
        with CorrectionScratch(scratch_dir, (len(wanted), 3, box.nk1, g.ny, g.nz)) as scratch:
            with progress_bar("correction", box.nk1, "slab", progress) as bar:
                for slabs, block in cond.correction_blocks(stencil, placed.streams, x, run.plane_times_s(), wanted,
                                                           g.ny, g.nz, gen.threads):  # fmt: skip
                    scratch.write(slabs, block)
                    bar.update(len(slabs))
            # read ahead in the generator's order: planes in time order, a plane's components in turn (frozen: one)
            order = [int(i) for i in np.argsort(run.plane_times_s(), kind="stable")]
            read = scratch.reader([(0 if frozen else ix, c) for ix in order[: 1 if frozen else None] for c in range(3)])

            def addend(ix: int, c: int) -> np.ndarray:  # added to the sample's spectra before their time transform
                return read(0 if frozen else ix, c).reshape(box.nk1, g.ny * g.nz)

            yield from gen.generate(None if conditional_mean else run.seed, run.plane_times_s(), addend)

    return report, planes()


def correction_disk_bytes(run: MannRun) -> int:
    """Bytes [B] of the correction's scratch file of ``run``."""
    g = run.grid
    frozen = run.params.evo_time_s is None or g.nx == 1
    return CorrectionScratch.nbytes(((1 if frozen else g.nx), 3, g.nt // 2 + 1, g.ny, g.nz))


def constraint_record(files, placed: PlacedData, report: cond.SolveReport, remeasured: np.ndarray,
                      conditional_mean: bool) -> dict:  # fmt: skip
    """The store's ``constraints`` record: the data on the grid, geometry, noise, the solver's report and the
    residual ``remeasured`` - data [m/s] (Mann and Kaimal runs alike)."""
    observed = np.isfinite(placed.data)
    resid = (remeasured - placed.data)[observed]
    return {
        "kind": sorted({s["kind"] for s in placed.geometry}),
        "files": [f.source for f in files],
        "conditional_mean": conditional_mean,
        "interpolation": "point series: linear onto the stored times t = T + x/U, bilinear in (y, z); lidar: the "
                         "virtual lidar's own operator (probe volume, Taylor shift, linear in t, bilinear in y, z)",
        "decimation": int(placed.streams.decimation),
        "streams": list(placed.geometry),
        "data_m_s": [[None if not math.isfinite(v) else float(v) for v in row] for row in placed.data],
        "n_samples": int(observed.sum()),
        "solver": {"method": report.method, "iterations": report.iterations,
                   "relative_residual": report.relative_residual, "tolerance": cond.CG_TOLERANCE},
        "residual_max_m_s": float(np.abs(resid).max()),
        "residual_rms_m_s": float(np.sqrt(np.mean(resid**2))),
    }  # fmt: skip


def run_mann_constrained(run: MannRun, out, files: list[PointSeries], *, noise_m_s: float | None = None,
                         conditional_mean: bool = False, overwrite: bool = False, chunk_t: int | None = None,
                         threads: int | None = None, cache_dir=None, progress: bool = False,
                         placed: PlacedData | None = None, fit: dict | None = None) -> dict:  # fmt: skip
    """Generate ``run`` conditioned on the point series (or lidar data) ``files`` into a new store at ``out``.

    ``run``'s seed draws u_s and eps_s. ``noise_m_s``: measurement-noise sigma [m/s] >= 0 replacing the files' own.
    ``conditional_mean``: write C H^T S^-1 d (no random part). ``progress``: bars of the stages on a terminal.
    ``placed``: ``place(run, files, noise_m_s)`` if the caller has it; ``fit``: the store's ``fit`` record
    (turbgen.runs.replay). Returns {path, seconds, sigma_/mean_ u/v/w [m/s], constraints}. ParameterError for
    measurements off the field or all missing, noise < 0, dependent zero-noise measurements; nothing written."""
    opener = partial(create_store, Path(out), run.grid, run.to_attrs(), chunk_t=chunk_t, overwrite=overwrite)
    return _conditioned(opener, run, files, str(out), noise_m_s=noise_m_s, conditional_mean=conditional_mean,
                        threads=threads, cache_dir=cache_dir, progress=progress, placed=placed, fit=fit)[1]


def mann_constrained_in_memory(run: MannRun, files: list, *, noise_m_s: float | None = None,
                               conditional_mean: bool = False, threads: int | None = None, cache_dir=None,
                               progress: bool = False, placed: PlacedData | None = None,
                               fit: dict | None = None):  # fmt: skip
    """The field of :func:`run_mann_constrained` in memory (values and attributes as that store's but
    ``created_utc``): (xarray.Dataset, summary with path None). ParameterError also if it does not fit in memory."""
    writer, summary = _conditioned(lambda: MemoryWriter(run.grid, run.to_attrs()), run, files, None,
                                   noise_m_s=noise_m_s, conditional_mean=conditional_mean, threads=threads,
                                   cache_dir=cache_dir, progress=progress, placed=placed, fit=fit)  # fmt: skip
    return writer.dataset, summary


def constrained_memory_bytes(run: MannRun, placed: PlacedData, threads: int) -> int:
    """Bytes [B] a constrained run holds besides its output: the generator's, S (nt/q x M x M
    complex128), one plane component's correction spectra, the stream arrays and the conditioning's workspace."""
    g, m = run.grid, placed.streams.n_streams
    extra = (g.nt * m * m * 16 + (g.nt // 2 + 1) * g.ny * g.nz * 8 + 8 * m * g.nt * 8
             + cond.workspace_bytes(synthesis_box(run), placed.streams, g.nx))  # fmt: skip
    return memory_estimate_bytes(run, threads) + extra


def _conditioned(open_writer, run: MannRun, files, path: str | None, *, noise_m_s, conditional_mean: bool, threads,
                 cache_dir, progress: bool, placed: PlacedData | None, fit: dict | None) -> tuple:
    """(writer, summary): the conditioned field of ``run`` into ``open_writer()``, opened once the system is solved:
    the store at ``path``, else (None) a MemoryWriter, whose field must fit in memory too and whose correction's
    scratch file goes to the temporary directory."""
    t_start = time.perf_counter()
    threads = default_threads(threads)
    placed = place(run, files, noise_m_s) if placed is None else placed
    g, field_bytes, in_memory = run.grid, 3 * run.grid.nbytes_per_component(), path is None
    require_memory(constrained_memory_bytes(run, placed, threads) + (field_bytes if in_memory else 0),
                   f"the constrained Mann run{' in memory' if in_memory else ''} ({placed.streams.n_streams} "
                   "measurement streams)", ("pass `out` to write a store, or lower" if in_memory else "lower")
                   + " `nt`, `ny`/`nz` or the number of measured series")  # fmt: skip
    if path is not None:
        scratch_dir = Path(path).absolute().parent
        require_disk(Path(path), correction_disk_bytes(run) + field_bytes, "the constrained Mann run (its store and "
                     "the correction's scratch file)", "free space or choose another `out`")  # fmt: skip
    else:
        scratch_dir = Path(tempfile.gettempdir())
        require_disk(scratch_dir, correction_disk_bytes(run), "the correction's scratch file of the constrained Mann "
                     "run", "free space in the temporary directory (TMPDIR)")  # fmt: skip
    stencil = build_mann_stencil(run, cache_dir)
    cov = stream_system(run, stencil, placed, threads, progress, cache_dir)
    report, planes = conditioned_planes(run, stencil, placed, cov, scratch_dir, conditional_mean=conditional_mean,
                                        threads=threads, progress=progress)  # fmt: skip
    with open_writer() as writer:
        remeasured, sums = write_planes(writer, placed, planes, lambda: progress_bar("write", g.nx, "plane", progress),
                                        background=True)  # fmt: skip
        record = constraint_record(files, placed, report, remeasured, conditional_mean)
        writer.add_attrs(constraints=record, **({} if fit is None else {"fit": fit}))
    return writer, field_summary(path, t_start, sums, g, constraints=record)


def write_planes(writer, placed: PlacedData, planes, bar=None, background: bool = False) -> tuple[np.ndarray, dict]:
    """Write the conditioned ``planes`` with ``writer`` and measure them again: (H u_c (M, nt/q), {component:
    [sum, sum of squares]}). ``bar()``: a progress bar made at the first plane. ``background``: each plane written in a
    thread while the next is made (planes in two alternating buffers); the results are the same."""
    remeasured = np.zeros(placed.data.shape)
    sums = {c: [0.0, 0.0] for c in COMPONENTS}
    progress = None

    def keep(ix: int, comp: str, value: np.ndarray) -> None:
        cond.measure(placed.streams, ix, COMPONENTS.index(comp), value, remeasured)
        total, squares = writer.write(comp, ix, value, squares=True)
        sums[comp][0] += total
        sums[comp][1] += squares

    # at most one plane in flight; leaving the pool waits for it, so an exception never races the writer's clean-up
    with ThreadPoolExecutor(1) as pool:
        pending = None
        for ix, comp, value in planes:
            progress = progress or (bar() if bar is not None else None)
            if progress is not None:
                progress.update(int(comp == COMPONENTS[-1]))
            if pending is not None:
                pending.result()
            if background:
                pending = pool.submit(keep, ix, comp, value)
            else:
                keep(ix, comp, value)
        if pending is not None:
            pending.result()
    if progress is not None:
        progress.close()
    return remeasured, sums


def load_constraint(path):
    """A constraint file: a ``turbgen lidar --out`` dataset, a line-of-sight CSV or netCDF file, or a point-series
    JSON or CSV file. ParameterError or StoreError if it does not match its format."""
    from turbgen.virtual_lidar.dataset import is_lidar_dataset, read_dataset
    from turbgen.virtual_lidar.los_csv import is_los_csv, read_los_csv
    from turbgen.virtual_lidar.los_netcdf import is_los_netcdf, read_los_netcdf
    from turbgen.spec.constraints import load_point_series
    from turbgen.spec.point_csv import is_point_csv

    if is_lidar_dataset(path):
        return read_dataset(path)
    if is_los_netcdf(path):
        return read_los_netcdf(path)
    return read_los_csv(path) if is_los_csv(path) and not is_point_csv(path) else load_point_series(path)


def describe_constraints(record: dict) -> list[str]:
    """Lines saying how a store was conditioned (from its ``constraints`` record)."""
    solver = record["solver"]
    how = "direct per-frequency solve" if solver["method"] == "circulant" else (
        f"conjugate gradients, {solver['iterations']} iterations")
    what = "conditional mean" if record["conditional_mean"] else "conditional sample"
    noise = sorted({s["noise_m_s"] for s in record["streams"]})
    winds = sorted({s["mean_wind"] for s in record["streams"] if s.get("mean_wind")})
    removed = [f"total-wind data: mean wind removed: {w} (export with it to get the data back)" for w in winds]
    return [
        f"constrained ({what}) on {len(record['streams'])} measured series, {record['n_samples']} samples from "
        f"{', '.join(record['files'])}; noise sigma {', '.join(f'{v:g}' for v in noise)} m/s",
        f"solve: {how}, relative residual {solver['relative_residual']:.1e}; field - data at the measurements: "
        f"max {record['residual_max_m_s']:.2e} m/s, rms {record['residual_rms_m_s']:.2e} m/s",
    ] + removed + off_wind_notes(record["streams"])


def off_wind_notes(streams: list) -> list[str]:
    """A note naming the sensor whose total-wind data blow furthest from the field's x, beyond OFF_WIND_DEG."""
    off = [s for s in streams if abs(s.get("direction_deg", 0.0)) > OFF_WIND_DEG]
    if not off:
        return []
    s = max(off, key=lambda s: abs(s["direction_deg"]))
    return [f"note: {s['name'].rsplit(':', 1)[0]}: after the file's mean wind the data still blow "
            f"{s['direction_deg']:+.1f} deg from the field's x (counter-clockwise from above; {len(off)} sensor(s) "
            f"beyond {OFF_WIND_DEG:g} deg): the mean of v went into the field as turbulence. Total-wind data belong "
            "in the field's frame (x along the mean wind): turn u and v, or replay with --fit (fit=True), which does"]


def load_constraints(files) -> list:
    """Each of ``files`` loaded (:func:`load_constraint`); PointSeries / LidarData are kept, a LidarReport gives
    its ``data()``. ParameterError for anything else."""
    from turbgen.virtual_lidar.dataset import LidarData
    from turbgen.virtual_lidar.report import LidarReport

    def one(f):
        if isinstance(f, (str, Path)) or hasattr(f, "__fspath__"):
            return load_constraint(f)
        if isinstance(f, (PointSeries, LidarData)):
            return f
        if isinstance(f, LidarReport):
            return f.data()
        raise ParameterError(f"constrain item {f!r:.60} is neither a constraint file's path, a PointSeries, "
                             "LidarData nor a lidar report (turbgen.runs.constrain.load_constraint)")

    return [one(f) for f in files]


def constraint_digest(placed: PlacedData, conditional_mean: bool) -> str:
    """8 hex digits of SHA-256 over the data as placed (values, noise, geometry) and ``conditional_mean``: the
    content, not the paths, names a constrained store."""
    import hashlib
    import json

    h = hashlib.sha256()
    h.update(np.ascontiguousarray(placed.data, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(placed.noise_m_s, dtype="<f8").tobytes())
    st = placed.streams
    for a in (st.plane, st.term_stream, st.term_component, st.term_iy, st.term_iz, st.term_shift, st.offset):
        h.update(np.ascontiguousarray(0 if a is None else a, dtype="<i8").tobytes())
    h.update(np.ascontiguousarray(st.term_weight, dtype="<f8").tobytes())
    h.update(json.dumps([int(st.decimation), bool(conditional_mean)]).encode())
    return h.hexdigest()[:8]


def constrained_store_name(run: MannRun, placed: PlacedData, conditional_mean: bool) -> str:
    """The run's default store name with ``_c<digest>`` (``mean`` for the conditional mean), e.g.
    mann_U16_L49_G3.1_evo400_s2_c1a2b3c4.zarr."""
    base = run.default_store_name().removesuffix(".zarr")
    return f"{base}_c{constraint_digest(placed, conditional_mean)}{'mean' if conditional_mean else ''}.zarr"


ENERGY_KEYS = ("ae", "sigma_u_m_s", "ti", "turb_class")  # a run mapping with none of them: ae from the data
_AE_TOLERANCE = 1e-6  # relative change of the fixed-point iteration of estimate_ae at which it stops
_AE_ITERATIONS = 50


def estimate_ae(run: MannRun, placed: PlacedData, cache_dir=None) -> tuple[float, int]:
    """alpha*eps^(2/3) [m^(4/3) s^-2] of the data, and the fixed-point iterations used.

    With S(a) = (a / a_0) (S_0 - R) + R, the estimate solves d^T S(a)^-1 d = n (d ~ N(0, S(a))): without noise in one
    step (the maximum-likelihood estimate; relative standard deviation sqrt(2 / n)), with noise by the monotone
    iteration a <- a d^T S(a)^-1 d / n."""
    stencil = build_mann_stencil(run, cache_dir)
    a0 = run.params.ae
    cov0 = stream_system(run, stencil, placed, cache_dir=cache_dir)
    m = placed.streams.n_streams
    noise = np.zeros_like(cov0)
    noise[:, np.arange(m), np.arange(m)] = placed.noise_m_s**2
    signal = cov0 - noise
    n = int(np.isfinite(placed.data).sum())
    a = a0
    for it in range(1, _AE_ITERATIONS + 1):
        cov = signal * (a / a0) + noise
        x, _ = solve_constraints(cov, placed, None, None)
        quad = float(np.sum(np.where(np.isfinite(placed.data), placed.data, 0.0) * x))
        new = a * quad / n
        if abs(new - a) <= _AE_TOLERANCE * a or not placed.noise_m_s.any():
            return new, it
        a = new
    raise ParameterError(f"the energy level ae estimated from the data did not converge in {_AE_ITERATIONS} "
                         f"iterations (last {a:.4g} m^(4/3)/s^2): give sigma_u, ti or ae")  # fmt: skip


def with_energy_from_data(mapping: dict, constraints: list, noise_m_s: float | None, cache_dir=None) -> MannRun:
    """The run of ``mapping``; without an energy level (ENERGY_KEYS) its ae is estimated from the data
    (:func:`estimate_ae`) and recorded in ``ae_from``."""
    from turbgen.theory.mann_spectra import variances

    run = MannRun.from_mapping(mapping)
    if any(key in mapping for key in ENERGY_KEYS):
        return run
    ae, iterations = estimate_ae(run, place(run, constraints, noise_m_s), cache_dir)
    est = MannRun.from_mapping({**mapping, "ae": ae})  # the record's model sigma_u (Mann 1994, Eq. 8 over k)
    how = (f"estimated from the constraint data (d^T S^-1 d = n, {iterations} iteration(s)): model sigma_u = "
           f"{math.sqrt(variances(est.params)['uu']):.4g} m/s")  # fmt: skip
    return MannRun.from_mapping({**mapping, "ae": ae, "ae_from": how})
