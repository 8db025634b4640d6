"""Constrained Kaimal runs: a Kaimal field conditioned on point time series or lidar LOS data (Hoffman & Ribak 1991).

Data placement, solver, the two passes and the ``constraints`` record are those of turbgen.runs.constrain; only the
prior differs: the Kaimal generator's per-bin covariance (turbgen.synthesis.kaimal_conditioning).

Record means: the synthesis has no bin 0, so every point's record mean is exactly 0 and a series observed at every
stored step cannot be matched in its mean. That mean is removed from the data (place_kaimal;
``record_mean_removed_m_s``, ``residual_*`` against the data minus it); the conditioning on the rest is exact
(with_mean_offset, kaimal_solve). Series observed every q > 1 steps keep their mean."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from dataclasses import fields as fields_of
from pathlib import Path

import numpy as np

from turbgen.resources import require_memory
from turbgen.runs.constrain import (PlacedData, combine_streams, constraint_record, measurement_noise, placed_streams,
                                    write_planes)  # fmt: skip
from turbgen.runs.mann import field_summary
from turbgen.runs.kaimal import kaimal_generator, memory_needed, store_attrs
from turbgen.spec.kaimal import KaimalRun
from turbgen.store import create_store
from turbgen.store.memory import MemoryWriter
from turbgen.synthesis import conditioning as cond
from turbgen.synthesis import kaimal_conditioning as kcond
from turbgen.synthesis.kaimal_evo import COMPONENTS


@dataclass(frozen=True, eq=False)
class KaimalPlaced(PlacedData):
    """PlacedData of a Kaimal run (:func:`place_kaimal`). ``full_rate``: per series observed at every step, the
    indices of the streams it was split into; ``record_mean_m_s`` (M,) [m/s]: the mean removed from each stream."""

    full_rate: tuple = ()
    record_mean_m_s: np.ndarray | None = None


def place_kaimal(run: KaimalRun, files: list, noise_m_s: float | None = None) -> KaimalPlaced:
    """turbgen.runs.constrain.place with the record mean of every full-rate series removed first."""
    series = placed_streams(run, files, noise_m_s)
    means = [float(np.mean(s.data[np.isfinite(s.data)])) if s.decimation == 1 else 0.0 for s in series]
    placed = combine_streams([replace(s, data=s.data - m) for s, m in zip(series, means)], run.grid.nt)
    parts = [placed.streams.decimation // s.decimation for s in series]  # consecutive streams per series
    start = np.concatenate([[0], np.cumsum(parts)])
    full_rate = tuple(np.arange(start[i], start[i + 1]) for i, s in enumerate(series) if s.decimation == 1)
    fields = {f.name: getattr(placed, f.name) for f in fields_of(PlacedData)}
    return KaimalPlaced(**fields, full_rate=full_rate, record_mean_m_s=np.repeat(means, parts))


def kaimal_stream_system(run: KaimalRun, placed: KaimalPlaced) -> np.ndarray:
    """The per-frequency S = H C H^T + R of ``run``'s prior (kaimal_conditioning.stream_covariance);
    ParameterError for dependent zero-noise measurements (record means aside, :func:`with_mean_offset`)."""
    cov = kcond.stream_covariance(kaimal_generator(run, workers=1), placed.streams, placed.noise_m_s**2)
    if np.any(placed.noise_m_s == 0):
        cond.check_singular(with_mean_offset(cov, placed), placed.streams.names)
    return cov


def with_mean_offset(cov: np.ndarray, placed: KaimalPlaced) -> np.ndarray:
    """``cov`` plus tau^2 v v^T at frequency 0 per full-rate series (v: the indicator of its streams, the
    direction of its record mean, which the field lacks; tau^2: their mean diagonal value). It changes S^-1 r only along
    v, which C H^T never sees: the solver's matrix when every sample is observed, else its preconditioner."""
    out = cov.copy()
    for group in placed.full_rate:
        out[0, group[:, None], group[None, :]] += float(np.mean(cov[:, group, group].real))
    return out


def kaimal_solve(cov: np.ndarray, placed: KaimalPlaced, measured: np.ndarray | None,
                 eps: np.ndarray | None) -> tuple[np.ndarray, cond.SolveReport]:  # fmt: skip
    """x = S^-1 (d - H u_s - eps_s) (``measured`` None: S^-1 d), (M, nt/q), zero at the missing samples: the
    circulant solve of :func:`with_mean_offset` when all is observed, else conjugate gradients preconditioned by it."""
    observed = np.isfinite(placed.data)
    r = placed.data if measured is None else placed.data - measured - eps
    r = np.where(observed, r, 0.0)
    pre = with_mean_offset(cov, placed)
    if observed.all():
        return cond.solve(pre, r, observed)
    return cond.solve(cov, r, observed, preconditioner=pre)


def _unconstrained_measurement(run: KaimalRun, placed: KaimalPlaced, threads: int | None) -> np.ndarray:
    """Pass 1: H u_s of the run's unconstrained sample (nothing kept)."""
    gen = kaimal_generator(run, workers=threads)
    out = np.zeros(placed.data.shape)
    for c, comp in enumerate(COMPONENTS):
        for ix, plane in gen.component_planes(comp):
            cond.measure(placed.streams, ix, c, plane, out)
    return out


def kaimal_conditioned_planes(run: KaimalRun, placed: KaimalPlaced, cov: np.ndarray, *, conditional_mean: bool = False,
                              threads: int | None = None):  # fmt: skip
    """The conditioned field of ``run``: (solver report, generator, iterator of (component, plane index,
    field (nt, ny, nz) float32 [m/s])); the generator made the field (its ``report`` complete after the iterator).
    Pass 1 runs here. ``cov``: kaimal_stream_system's."""
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
    """Peak bytes [B] of a constrained run: memory_needed plus S (nt/q x M x M complex128), one component's correction
    spectra and longitudinal factors on the measured planes, one plane's correction and the stream arrays."""
    g, m = run.grid, placed.streams.n_streams
    sampler = kaimal_generator(run, workers=threads).sampler_bytes()
    nf, q = g.nt // 2 + 1, len(placed.streams.used_planes())
    extra = (g.nt // placed.streams.decimation * m * m * 16 + q * nf * g.ny * g.nz * 8 + nf * g.nx * q * 8
             + nf * g.ny * g.nz * 16 + g.nt * g.ny * g.nz * 8 + 8 * m * g.nt * 8)  # fmt: skip
    return memory_needed(g, sampler=sampler) + extra


def require_constrained_memory(run: KaimalRun, placed: KaimalPlaced, threads: int | None = None,
                               field_bytes: int = 0) -> None:
    """ParameterError when :func:`constrained_memory_bytes` plus ``field_bytes`` exceed the available
    memory (the spectrum stays in memory)."""
    require_memory(constrained_memory_bytes(run, placed, threads) + field_bytes,
                   f"the constrained Kaimal run ({placed.streams.n_streams} measurement streams)",
                   "lower `nt`, `ny`/`nz` or the number of measured series")  # fmt: skip


def run_kaimal_constrained(run: KaimalRun, out, files: list, *, noise_m_s: float | None = None,
                           conditional_mean: bool = False, overwrite: bool = False, chunk_t: int | None = None,
                           threads: int | None = None) -> dict:  # fmt: skip
    """Generate ``run`` conditioned on ``files`` (PointSeries or lidar data) into a new store at ``out``; arguments,
    summary (with the synthesis report) and errors as turbgen.runs.constrain.run_mann_constrained's."""
    return _conditioned(run, files, noise_m_s, conditional_mean, threads, str(out), lambda attrs: create_store(
        Path(out), run.grid, attrs, chunk_t=chunk_t, overwrite=overwrite))[1]


def kaimal_constrained_in_memory(run: KaimalRun, files: list, *, noise_m_s: float | None = None,
                                 conditional_mean: bool = False, threads: int | None = None):  # fmt: skip
    """The field of :func:`run_kaimal_constrained` in memory: (xarray.Dataset, summary with path
    None); ParameterError also when the run with its field does not fit in memory."""
    return _conditioned(run, files, noise_m_s, conditional_mean, threads, None,
                        lambda attrs: MemoryWriter(run.grid, attrs))  # fmt: skip


def _conditioned(run: KaimalRun, files: list, noise_m_s, conditional_mean: bool, threads, path, open_writer):
    """(dataset or None, summary) of ``run`` conditioned on ``files`` into ``open_writer(attrs)`` (a MemoryWriter
    when ``path`` is None, whose field must fit in memory too)."""
    t_start = time.perf_counter()
    placed = place_kaimal(run, files, noise_m_s)
    g = run.grid
    require_constrained_memory(run, placed, threads, 0 if path is not None else 3 * g.nbytes_per_component())
    cov = kaimal_stream_system(run, placed)
    report, gen, planes = kaimal_conditioned_planes(run, placed, cov, conditional_mean=conditional_mean,
                                                    threads=threads)  # fmt: skip
    with open_writer(store_attrs(run, gen)) as writer:
        remeasured, sums = write_planes(writer, placed, ((ix, comp, value) for comp, ix, value in planes))
        record = constraint_record(files, placed, report, remeasured, conditional_mean)
        record["record_mean_removed_m_s"] = [float(v) for v in placed.record_mean_m_s]
        writer.add_attrs(synthesis_report=gen.report, constraints=record)
    summary = field_summary(path, t_start, sums, g, constraints=record)
    summary["expected_sigma"] = [math.sqrt(gen.expected_variance(c)) for c in COMPONENTS]
    summary.update(gen.report)
    return getattr(writer, "dataset", None), summary
