"""Constrained Kaimal runs: a Kaimal field conditioned on measured point time series or lidar LOS data (Hoffman &
Ribak 1991).

    summary = run_kaimal_constrained(run, "mast.zarr", [load_point_series("mast.json")], noise_m_s=0.1)

The data are placed on the grid exactly as for Mann runs (turbgen.runs.constrain.placed_streams: plane at x, stored time
T + x/U, linear in time, bilinear in (y, z); the virtual lidar's own operator for LOS data), and solved with the same
circulant / preconditioned-conjugate-gradient solver; only the prior differs: the Kaimal generator's own per-bin
covariance (turbgen.synthesis.kaimal_conditioning). Pass 1 generates the unconstrained sample u_s of the run's seed and
measures it (nothing kept); pass 2 generates it again (bit-identical) and adds C H^T S^-1 (d - H u_s - eps_s) plane by
plane while writing. ``conditional_mean=True`` writes C H^T S^-1 d only. The store gets the same ``constraints``
record as a constrained Mann store (turbgen info and turbgen validate read it).

Record means: the Kaimal synthesis has no bin 0 (v_0 = 0), so every point's record mean is exactly 0 in every field it
makes, and the record mean of a series observed at every stored step (a point series; a lidar scanning every step)
is no property of the field. Each such series' mean over its observed samples is therefore removed from the data
(place_kaimal; recorded as ``record_mean_removed_m_s``; ``residual_*`` are then against the data minus it); the
conditioning on the rest is exact (with_mean_offset, kaimal_solve), and with zero noise the field reproduces the data
minus that mean. Series observed every q > 1 steps keep their mean (the field's decimated series have one).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from dataclasses import fields as fields_of
from pathlib import Path

import numpy as np

from turbgen.resources import require_memory
from turbgen.runs.constrain import (PlacedData, combine_streams, conditioned_summary, constraint_record, measurement_noise,
                                    placed_streams, write_planes)  # fmt: skip
from turbgen.runs.kaimal import kaimal_generator, memory_needed, store_attrs
from turbgen.spec.kaimal import KaimalRun
from turbgen.store import create_store
from turbgen.store.memory import MemoryWriter
from turbgen.synthesis import conditioning as cond
from turbgen.synthesis import kaimal_conditioning as kcond
from turbgen.synthesis.kaimal_evo import COMPONENTS


@dataclass(frozen=True, eq=False)
class KaimalPlaced(PlacedData):
    """Measurements on a Kaimal run's grid (:func:`place_kaimal`): PlacedData whose full-rate series have their record
    mean removed. ``full_rate``: for every series observed at every stored step, the indices of the streams it was
    split into (one, or Q of them when other streams are observed every Q steps); ``record_mean_m_s`` (M,) [m/s]:
    the mean removed from each stream's series (0 for the others)."""

    full_rate: tuple = ()
    record_mean_m_s: np.ndarray | None = None


def place_kaimal(run: KaimalRun, files: list, noise_m_s: float | None = None) -> KaimalPlaced:
    """turbgen.runs.constrain.place for a Kaimal run, the record mean of every full-rate series (over its observed
    samples) removed before the streams are combined (module docstring)."""
    series = placed_streams(run, files, noise_m_s)
    means = [float(np.mean(s.data[np.isfinite(s.data)])) if s.decimation == 1 else 0.0 for s in series]
    placed = combine_streams([replace(s, data=s.data - m) for s, m in zip(series, means)], run.grid.nt)
    parts = [placed.streams.decimation // s.decimation for s in series]  # consecutive streams per series
    start = np.concatenate([[0], np.cumsum(parts)])
    full_rate = tuple(np.arange(start[i], start[i + 1]) for i, s in enumerate(series) if s.decimation == 1)
    fields = {f.name: getattr(placed, f.name) for f in fields_of(PlacedData)}
    return KaimalPlaced(**fields, full_rate=full_rate, record_mean_m_s=np.repeat(means, parts))


def kaimal_stream_system(run: KaimalRun, placed: KaimalPlaced) -> np.ndarray:
    """The per-frequency matrices of S = H C H^T + R for ``run``'s prior (kaimal_conditioning.stream_covariance).

    Raises ParameterError when zero-noise measurements are linearly dependent (naming them; the record means of
    full-rate series aside, see :func:`with_mean_offset`)."""
    cov = kcond.stream_covariance(kaimal_generator(run, workers=1), placed.streams, placed.noise_m_s**2)
    if np.any(placed.noise_m_s == 0):
        cond.check_singular(with_mean_offset(cov, placed), placed.streams.names)
    return cov


def with_mean_offset(cov: np.ndarray, placed: KaimalPlaced) -> np.ndarray:
    """``cov`` plus, at frequency 0, tau^2 v v^T for every full-rate series: v the indicator of its streams (the
    direction of its record mean, which the field does not have: S_0 v = R v, 0 with zero noise), tau^2 its streams'
    mean diagonal value over the frequencies (a scale). With the record mean removed, and a noise common to the
    series' streams, it changes S^-1 r only along v, which C H^T never sees (C H^T v = 0); the solver uses it where
    every sample is observed and as the preconditioner otherwise (module docstring)."""
    out = cov.copy()
    for group in placed.full_rate:
        tau2 = float(np.mean(cov[:, group, group].real))
        out[0, group[:, None], group[None, :]] += tau2
    return out


def kaimal_solve(cov: np.ndarray, placed: KaimalPlaced, measured: np.ndarray | None,
                 eps: np.ndarray | None) -> tuple[np.ndarray, cond.SolveReport]:  # fmt: skip
    """x = S^-1 (d - H u_s - eps_s) (or S^-1 d when ``measured`` is None), (M, nt/q), zero at the missing samples:
    the circulant solve of :func:`with_mean_offset` when every sample is observed, else conjugate gradients on the
    exact S restricted to the observed samples with it as preconditioner."""
    observed = np.isfinite(placed.data)
    r = placed.data if measured is None else placed.data - measured - eps
    r = np.where(observed, r, 0.0)
    pre = with_mean_offset(cov, placed)
    if observed.all():
        return cond.solve(pre, r, observed)
    return cond.solve(cov, r, observed, preconditioner=pre)


def _unconstrained_measurement(run: KaimalRun, placed: KaimalPlaced, threads: int | None) -> np.ndarray:
    """Pass 1: H u_s of the unconstrained sample of the run's seed (nothing is kept)."""
    gen = kaimal_generator(run, workers=threads)
    out = np.zeros(placed.data.shape)
    for c, comp in enumerate(COMPONENTS):
        for ix, plane in gen.component_planes(comp):
            cond.measure(placed.streams, ix, c, plane, out)
    return out


def kaimal_conditioned_planes(run: KaimalRun, placed: KaimalPlaced, cov: np.ndarray, *, conditional_mean: bool = False,
                              threads: int | None = None):  # fmt: skip
    """The conditioned field of ``run``: (solver report, generator, iterator of (component, plane index, field
    (nt, ny, nz) float32 [m/s])); ``generator`` is the one whose samplers made the field (u_s's, or with
    ``conditional_mean`` the correction's alone; its ``report`` is complete once the iterator is exhausted).

    A conditional sample u_s + C H^T S^-1 (d - H u_s - eps_s) (pass 1 here, before returning; the iterator makes u_s
    again and adds the correction), or with ``conditional_mean`` C H^T S^-1 d. ``cov``: kaimal_stream_system.
    """
    g = run.grid
    measured = eps = None
    if not conditional_mean:
        measured, eps = _unconstrained_measurement(run, placed, threads), measurement_noise(run, placed)
    x, report = kaimal_solve(cov, placed, measured, eps)
    gen = kaimal_generator(run, workers=threads)
    prior = kaimal_generator(run, workers=1)  # its samplers for C H^T x (the field's generator keeps its own report)

    def planes():
        for comp in COMPONENTS:
            fix = kcond.correction(prior, placed.streams, x, comp)
            source = (((ix, None) for ix in range(g.nx)) if conditional_mean else gen.component_planes(comp))
            for ix, field in source:
                value = fix.field(ix, g.nt).astype(np.float32)
                if field is not None:
                    value += field
                yield comp, ix, value

    return report, prior if conditional_mean else gen, planes()


def constrained_memory_bytes(run: KaimalRun, placed: KaimalPlaced, threads: int | None = None) -> int:
    """Peak bytes of a constrained run: the generator's in-memory run plus S (nt/q x M x M complex), one component's
    correction spectra on the measured planes (complex64) and its longitudinal factors, one plane's correction
    (float64 spectrum and field) and the stream arrays."""
    g, m = run.grid, placed.streams.n_streams
    sampler = kaimal_generator(run, workers=threads).sampler_bytes()
    nf, q = g.nt // 2 + 1, len(placed.streams.used_planes())
    extra = (g.nt // placed.streams.decimation * m * m * 16 + q * nf * g.ny * g.nz * 8 + nf * g.nx * q * 8
             + nf * g.ny * g.nz * 16 + g.nt * g.ny * g.nz * 8 + 8 * m * g.nt * 8)  # fmt: skip
    return memory_needed(g, sampler=sampler) + extra


def require_constrained_memory(run: KaimalRun, placed: KaimalPlaced, threads: int | None = None,
                               field_bytes: int = 0) -> None:
    """Refuse (ParameterError) a constrained run whose :func:`constrained_memory_bytes`, plus ``field_bytes`` (its
    field in memory), exceed the available memory (constrained runs keep the spectrum in memory: no scratch file)."""
    require_memory(constrained_memory_bytes(run, placed, threads) + field_bytes,
                   f"the constrained Kaimal run ({placed.streams.n_streams} measurement streams)",
                   "lower `nt`, `ny`/`nz` or the number of measured series")  # fmt: skip


def run_kaimal_constrained(run: KaimalRun, out, files: list, *, noise_m_s: float | None = None,
                           conditional_mean: bool = False, overwrite: bool = False, chunk_t: int | None = None,
                           threads: int | None = None) -> dict:  # fmt: skip
    """Generate ``run`` conditioned on ``files`` into a new store at ``out``.

    Parameters
    ----------
    run : KaimalRun
        The run (its seed draws u_s and eps_s).
    out : str or path-like
        The new store.
    files : list
        The measurements: PointSeries (turbgen.spec.constraints.load_point_series) or lidar datasets
        (turbgen.runs.constrain.load_constraint).
    noise_m_s : float, optional
        Measurement-noise sigma [m/s] >= 0 for every value, replacing the files' own.
    conditional_mean : bool
        Write the conditional mean C H^T S^-1 d (no random part) instead of a conditional sample.

    Returns
    -------
    dict
        path, seconds, sigma_/mean_ u/v/w [m/s], the synthesis report and ``constraints`` (the record written to the
        store).

    Raises
    ------
    ParameterError
        For measurements off the field, all missing, noise < 0, dependent zero-noise measurements; nothing written.
    """
    return _conditioned(run, files, noise_m_s, conditional_mean, threads, str(out), lambda attrs: create_store(
        Path(out), run.grid, attrs, chunk_t=chunk_t, overwrite=overwrite))[1]


def kaimal_constrained_in_memory(run: KaimalRun, files: list, *, noise_m_s: float | None = None,
                                 conditional_mean: bool = False, threads: int | None = None):  # fmt: skip
    """The field of :func:`run_kaimal_constrained` in memory, as its store would open: (xarray.Dataset, summary).

    The same values and attributes (but ``created_utc``) as that store (turbgen.store.memory.MemoryWriter); the
    arguments as run_kaimal_constrained's; the summary's path is None. Raises ParameterError as it does, and when the
    run with its field does not fit the available memory.
    """
    return _conditioned(run, files, noise_m_s, conditional_mean, threads, None,
                        lambda attrs: MemoryWriter(run.grid, attrs))  # fmt: skip


def _conditioned(run: KaimalRun, files: list, noise_m_s, conditional_mean: bool, threads, path, open_writer):
    """(the writer's dataset or None, summary) of ``run`` conditioned on ``files`` into ``open_writer(attrs)`` (a
    store's writer, or a MemoryWriter when ``path`` is None, whose field then also has to fit in memory)."""
    t_start = time.perf_counter()
    placed = place_kaimal(run, files, noise_m_s)
    g = run.grid
    field_bytes = 0 if path is not None else 3 * g.nbytes_per_component()
    require_constrained_memory(run, placed, threads, field_bytes)
    cov = kaimal_stream_system(run, placed)
    report, gen, planes = kaimal_conditioned_planes(run, placed, cov, conditional_mean=conditional_mean,
                                                    threads=threads)  # fmt: skip
    with open_writer(store_attrs(run, gen)) as writer:
        remeasured, sums = write_planes(writer, placed, ((ix, comp, value) for comp, ix, value in planes))
        record = constraint_record(files, placed, report, remeasured, conditional_mean)
        record["record_mean_removed_m_s"] = [float(v) for v in placed.record_mean_m_s]
        writer.add_attrs(synthesis_report=gen.report, constraints=record)
    summary = conditioned_summary(path, t_start, record, sums, g)
    summary["expected_sigma"] = [math.sqrt(gen.expected_variance(c)) for c in COMPONENTS]
    summary.update(gen.report)
    return getattr(writer, "dataset", None), summary
