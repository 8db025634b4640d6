"""The worker side of a sweep: one task per run (generate, checksum, validate, lidar) and the pool size."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, replace

from turbgen import fft
from turbgen.errors import one_line
from turbgen.resources import available_memory_bytes
from turbgen.runs.models import MODELS
from turbgen.sweep.manifest import store_checksum


@dataclass(frozen=True)
class RunTask:
    """What a worker needs for one run."""

    model: str  # a key of turbgen.runs.models.MODELS
    run: object
    path: str
    overwrite: bool  # replace an incomplete store
    chunk_t: int | None
    validate: bool
    generate: bool = True  # False: only checksum, validate, lidar an existing store
    threads: int | None = None  # None: all cores
    memory_bytes: int | None = None  # the run's budget [B] (a Mann run over it goes out of core)
    lidar: str | None = None  # preset or file
    constraints: object = None
    cache_dir: str | None = None  # a constrained run's stencil cache
    fft_backend: str | None = None  # None: the worker's current one


def validate_store(path: str, threads: int | None = None) -> dict:
    """Summary of turbgen.validate on one store: ``passed``, ``failed``, ``max_abs_z`` (metric -> [max |z|,
    z_crit]), ``seconds``."""
    from turbgen.validation import validate

    rep = validate(path, workers=threads)
    return {
        "passed": rep.passed,
        "failed": rep.failed,
        "max_abs_z": {m.name: [round(m.max_abs_z, 3), round(m.z_crit, 3)] for m in rep.metrics},
        "seconds": round(rep.seconds["total"], 3),
    }


def lidar_store(path: str, lidar: str) -> dict:
    """Summary of the virtual lidar on one store: ``passed``, ``simulated``, ``theory``, ``max_abs_z``, ``z_crit``."""
    from turbgen.virtual_lidar.report import lidar_report
    from turbgen.store import open_store

    d = lidar_report(open_store(path), lidar).to_dict()
    return {"passed": d["verdict"]["passed"], "simulated": d["simulated"], "theory": d["theory"],
            "max_abs_z": d["verdict"]["max_abs_z"], "z_crit": d["verdict"]["z_crit"]}


def execute_run(task: RunTask, shared=None) -> dict:
    """Worker side: generate one field, checksum it, optionally validate it and run the lidar; never raises.
    Returns ``status`` ("complete" or "failed"), ``duration_s`` [s] and as available ``sigma_m_s`` [m/s],
    ``checksum``, ``validation``, ``lidar`` and ``error`` (one line); a validator or lidar crash leaves the run complete.
    """
    t0 = time.perf_counter()
    out: dict = {"status": "failed"}
    try:
        with fft.use(task.fft_backend):
            _execute_run(task, shared, out)
        out["status"] = "complete"
    except Exception as exc:
        out["error"] = one_line(exc)
    out["duration_s"] = round(time.perf_counter() - t0, 3)
    return out


def _execute_run(task: RunTask, shared, out: dict) -> None:
    """execute_run's steps, their results into ``out``."""
    if task.generate and task.constraints is not None:  # as `turbgen mann --constrain`
        from turbgen.runs.constrain import load_constraints, run_mann_constrained

        c = task.constraints
        summary = run_mann_constrained(task.run, task.path, load_constraints(c.files), noise_m_s=c.noise_m_s,
                                       conditional_mean=c.conditional_mean, overwrite=task.overwrite,
                                       chunk_t=task.chunk_t, threads=task.threads, cache_dir=task.cache_dir)  # fmt: skip
        out["sigma_m_s"] = [float(summary[f"sigma_{c}"]) for c in "uvw"]
    elif task.generate:
        summary = MODELS[task.model].run(task.run, task.path, overwrite=task.overwrite, chunk_t=task.chunk_t,
                                         threads=task.threads, memory_bytes=task.memory_bytes, shared=shared)
        sig = [summary.get(f"sigma_{c}") for c in "uvw"]
        out["sigma_m_s"] = [None if s is None else float(s) for s in sig]
    out["checksum"] = store_checksum(task.path)
    if task.validate:
        try:
            out["validation"] = validate_store(task.path, task.threads)
        except Exception as exc:  # a validator crash is recorded, the field itself is fine
            out["validation"] = {"passed": False, "error": one_line(exc)}
    if task.lidar:
        try:
            out["lidar"] = lidar_store(task.path, task.lidar)
        except Exception as exc:  # recorded like a validator crash: the field itself is fine
            out["lidar"] = {"passed": False, "error": one_line(exc)}


def task_bytes(task: RunTask) -> int:
    """Peak memory [B] of one run with one thread (the shared Mann stencil included), at most its budget for a run
    that can go out of core."""
    model = MODELS[task.model]
    need = model.memory_bytes(task.run, 1)
    if task.generate and model.shared_part(task.run, task.threads, task.memory_bytes) is not None:
        need += model.shared_bytes(task.run)  # the shared part, held besides the run's own
    return need if task.memory_bytes is None or not model.out_of_core else min(need, task.memory_bytes)


def default_workers(tasks) -> int:
    """LocalCluster size (>= 1): one worker per core, at most one per run, as many as fit in 80 % of the memory."""
    tasks = list(tasks)
    n = min(os.cpu_count() or 1, len(tasks))
    avail = available_memory_bytes()
    if avail and tasks:
        # the seed changes no memory: one estimate per distinct run (a Kaimal estimate sizes its tori)
        distinct = {(t.model, replace(t.run, seed=0), t.generate, t.threads, t.memory_bytes): t for t in tasks}
        n = min(n, int(0.8 * avail) // max(task_bytes(t) for t in distinct.values()))
    return max(1, n)
