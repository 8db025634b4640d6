"""Execute a sweep plan on dask.distributed: resumable, idempotent, one lock per output directory.

* A LocalCluster sized to the machine (one single-threaded worker process per core, at most one
  per run and as many as fit in 80 % of the available memory; each run gets cores/workers
  threads) or an existing scheduler (plan.scheduler; its workers must see the output directory
  at the same path).
* Runs that differ only in the seed or in ae (TI, turbulence class) share one ae-free Mann stencil:
  it is built once as a dask task and passed to each run task (dask ships it to the workers that
  need it), which scales it to its ae.
* Before anything is submitted, every planned store is inspected: complete stores with the planned
  parameters are kept ("skipped"), stores with other parameters are never overwritten (the run
  is recorded as failed), incomplete stores are regenerated, and temporary directories left by
  dead writers on this host are removed.
* A planned store that exists with other parameters or another grid is never overwritten: the
  sweep is refused before anything is written (the manifest keeps its records). Existing complete
  stores with other time chunks than --chunks are kept and reported in one line.
* A failing run is recorded with its error; the others continue. The manifest is rewritten
  (atomically) after every finished run, so an interrupted sweep leaves an accurate record; records
  of runs from earlier sweeps into the same directory that are not in this plan are kept.
* Ctrl-C, SIGTERM, SIGHUP: the local workers ignore SIGINT/SIGHUP (the sweep shuts them down), every
  run still pending is re-inspected on disk (a store its worker completed is recorded complete),
  the manifest is saved and the interruption propagates (CLI: one line, exit 130 / 128 + signal).
"""

from __future__ import annotations

import json
import logging
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError, StoreError
from turbgen.resources import available_memory_bytes, require_disk
from turbgen.store import open_store
from turbgen.store.layout import grid_to_attrs
from turbgen.store.temporaries import exit_on_signals, remove_dead_temporaries, report_removed
from turbgen.sweep.lock import SweepLock
from turbgen.sweep.manifest import MANIFEST_CSV, MANIFEST_JSON, read_manifest, store_checksum, utc_now, write_manifest
from turbgen.sweep.plan import PlannedRun, SweepPlan


@dataclass(frozen=True)
class RunTask:
    """What a worker needs for one run: generate (unless only checksumming an existing store)."""

    model: str
    run: object
    path: str
    overwrite: bool
    chunk_t: int | None
    validate: bool
    generate: bool = True
    threads: int | None = None  # threads of one run (None: os.cpu_count(); never changes the field)
    memory_bytes: int | None = None  # memory budget of one run: a Mann run that does not fit goes out of core
    lidar: str | None = None  # lidar preset or file to run on the field (turbgen lidar)


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}".rstrip(": ")


def validate_store(path: str, threads: int | None = None) -> dict:
    """Summary of turbgen.validate on one store: passed, failed metrics, worst |z| vs critical z per metric."""
    from turbgen.validate import validate

    rep = validate(path, workers=threads)
    return {
        "passed": rep.passed,
        "failed": rep.failed,
        "max_abs_z": {m.name: [round(m.max_abs_z, 3), round(m.z_crit, 3)] for m in rep.metrics},
        "seconds": round(sum(rep.seconds.values()), 3),
    }


def lidar_store(path: str, lidar: str) -> dict:
    """Summary of the virtual lidar on one store: verdict, simulated and theoretical k_0.5 and cut-off."""
    from turbgen.lidar.report import lidar_report
    from turbgen.store import open_store

    d = lidar_report(open_store(path), lidar).to_dict()
    return {"passed": d["verdict"]["passed"], "simulated": d["simulated"], "theory": d["theory"],
            "max_abs_z": d["verdict"]["max_abs_z"], "z_crit": d["verdict"]["z_crit"]}


def _out_of_core(task: RunTask) -> bool:
    """Whether a Mann run exceeds its memory budget (then turbgen.runs.mann_outofcore makes it)."""
    if task.model != "mann" or task.memory_bytes is None:
        return False
    from turbgen.runs.mann import memory_estimate_bytes
    from turbgen.runs.mann_outofcore import BASE_BYTES

    return memory_estimate_bytes(task.run, task.threads or os.cpu_count() or 1) + BASE_BYTES > task.memory_bytes


def execute_run(task: RunTask, stencil=None) -> dict:
    """Worker side: generate one field, checksum it, optionally validate it. Never raises."""
    t0 = time.perf_counter()
    out: dict = {"status": "failed"}
    try:
        if task.generate:
            if _out_of_core(task):
                from turbgen.runs.mann_outofcore import run_mann_outofcore

                summary = run_mann_outofcore(task.run, task.path, memory_bytes=task.memory_bytes,
                                             overwrite=task.overwrite, chunk_t=task.chunk_t, threads=task.threads)
            elif task.model == "mann":
                from turbgen.runs.mann import run_mann

                summary = run_mann(task.run, task.path, overwrite=task.overwrite, chunk_t=task.chunk_t, stencil=stencil,
                                   threads=task.threads)
            else:
                from turbgen.runs.kaimal import run_kaimal

                summary = run_kaimal(task.run, task.path, overwrite=task.overwrite, chunk_t=task.chunk_t,
                                     threads=task.threads)
            sig = [summary.get(f"sigma_{c}") for c in "uvw"]
            out["sigma_m_s"] = [None if s is None else float(s) for s in sig]
        out["checksum"] = store_checksum(task.path)
        if task.validate:
            try:
                out["validation"] = validate_store(task.path, task.threads)
            except Exception as exc:  # a validator crash is recorded, the field itself is fine
                out["validation"] = {"passed": False, "error": _one_line(exc)}
        if task.lidar:
            try:
                out["lidar"] = lidar_store(task.path, task.lidar)
            except Exception as exc:  # recorded like a validator crash: the field itself is fine
                out["lidar"] = {"passed": False, "error": _one_line(exc)}
        out["status"] = "complete"
    except Exception as exc:
        out["error"] = _one_line(exc)
    out["duration_s"] = round(time.perf_counter() - t0, 3)
    return out


def _norm(value):
    """JSON round trip: tuples -> lists, so attributes read back compare equal to planned ones."""
    return json.loads(json.dumps(value, default=lambda o: o.item() if hasattr(o, "item") else list(o)))


def _identity(model, attrs: dict, grid: dict) -> dict:
    keys = ("parameters", "seed", "U_m_s", "hub_height_m")
    return _norm({"model": model, **{k: attrs.get(k) for k in keys}, "grid": grid})


def store_state(path: Path, pr: PlannedRun) -> tuple[str, str | None]:
    """('absent' | 'incomplete' | 'mismatch' | 'complete', detail) of a planned run's store."""
    if not path.exists():
        return "absent", None
    try:
        fs = open_store(path)
    except StoreError as exc:
        return "incomplete", str(exc)
    planned_grid = grid_to_attrs(pr.run.grid)
    stored = _identity(fs.attrs.get("model"), fs.attrs, fs.attrs.get("grid"))
    planned = _identity(pr.model, pr.run.to_attrs(), planned_grid)
    if stored != planned:
        diff = sorted(k for k in planned if planned[k] != stored.get(k))
        return "mismatch", f"{path.name} exists with different {', '.join(diff)}; not overwritten"
    return "complete", None


def remove_dead_temps(directory: Path, names) -> list[Path]:
    """Remove temporaries ('.NAME.tmp-PID-...') of stores ``names`` and of the manifests whose writer
    pid is dead on this host."""
    return remove_dead_temporaries(directory, [*names, MANIFEST_JSON, MANIFEST_CSV])


@dataclass
class SweepResult:
    """Records of every planned run (manifest order) and what this invocation did."""

    out: Path
    records: list[dict]
    ran: int = 0
    skipped: int = 0
    seconds: float = 0.0
    failed: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when every planned run has a complete store."""
        return all(r["status"] == "complete" for r in self.records)

    @property
    def validation_failed(self) -> list[str]:
        """Runs whose field failed validation (only when the sweep validates)."""
        return [r["name"] for r in self.records if r.get("validation") and not r["validation"].get("passed")]

    @property
    def lidar_failed(self) -> list[str]:
        """Runs whose virtual-lidar coherence departed from theory (only when the sweep runs a lidar)."""
        return [r["name"] for r in self.records if r.get("lidar") and not r["lidar"].get("passed")]


def _base_record(pr: PlannedRun) -> dict:
    return {
        "name": pr.name,
        "model": pr.model,
        "preset": pr.preset,
        "U_m_s": pr.U_m_s,
        "seed": pr.seed,
        "path": pr.store_name,
        "status": "pending",
        "action": "none",
        "duration_s": None,
        "checksum": None,
        "sigma_m_s": None,
        "validation": None,
        "lidar": None,
        "error": None,
        "finished_utc": None,
        "parameters": _norm(pr.run.to_attrs()["parameters"]),
    }


def _task_bytes(task: RunTask) -> int:
    """Peak memory of one run (its generator's own estimate; a Mann stencil included)."""
    if task.model == "mann":
        from turbgen.runs.mann import memory_estimate_bytes

        from turbgen.runs.stencil_cache import shared_stencil_nbytes

        need = memory_estimate_bytes(task.run, 1) + shared_stencil_nbytes(task.run)
        return need if task.memory_bytes is None else min(need, task.memory_bytes)
    from turbgen.runs.kaimal import memory_needed

    return memory_needed(task.run.grid)


def default_workers(tasks) -> int:
    """LocalCluster size: one worker per core, at most one per run, and as many as fit in 80 % of the memory."""
    tasks = list(tasks)
    n = min(os.cpu_count() or 1, len(tasks))
    avail = available_memory_bytes()
    if avail and tasks:
        n = min(n, int(0.8 * avail) // max(_task_bytes(t) for t in tasks))
    return max(1, n)


def _make_client(plan: SweepPlan, n: int, processes: bool):
    from distributed import Client, LocalCluster

    if plan.scheduler:
        return Client(plan.scheduler), None
    if processes and threading.current_thread() is threading.main_thread():
        # multiprocessing's resource tracker (a helper process) masks SIGINT/SIGTERM but not SIGHUP:
        # start it with SIGHUP ignored so a hang-up does not kill it (tracebacks on relaunch)
        from multiprocessing import resource_tracker

        old = signal.signal(signal.SIGHUP, signal.SIG_IGN)
        try:
            resource_tracker.ensure_running()
        finally:
            signal.signal(signal.SIGHUP, old)
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=processes,
        dashboard_address=None,
        silence_logs=logging.ERROR,
    )
    client = Client(cluster)
    if processes:
        # a terminal's Ctrl-C (or hang-up) goes to the whole process group: let it reach the sweep
        # alone, which shuts the workers down, instead of ~80 lines of tracebacks from every worker
        client.run(_ignore_interrupts)
    return client, cluster


def _ignore_interrupts() -> None:
    """Worker side (its main thread): ignore SIGINT and SIGHUP."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)


def _check_out(out: Path) -> None:
    """One-line errors for an --out that cannot hold a sweep (a file, under a file, read-only)."""
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {out} is a file, not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError(f"--out {out} cannot be created: {exc.strerror} ({exc.filename})") from None
    if not os.access(out, os.W_OK):
        raise ParameterError(f"--out {out} is not writable")


def _settle_interrupted(plan: SweepPlan, records: dict) -> None:
    """After an interruption: record as complete the pending runs whose store a worker completed."""
    for pr in plan.runs:
        rec = records[pr.name]
        if rec["status"] != "pending":
            continue
        state, _ = store_state(plan.out / pr.store_name, pr)
        if state == "complete":  # checksum left empty: the next run of the sweep fills it in
            rec.update(status="complete", action="ran", error=None, finished_utc=utc_now())
        else:
            rec["error"] = "interrupted before this run finished"


def run_sweep(plan: SweepPlan, *, client=None, processes: bool = True, progress: bool = True,
              threads: int | None = None, memory_bytes: int | None = None) -> SweepResult:
    """Run every planned field that has no complete store yet; write DIR/manifest.{json,csv}.

    ``client``: an existing dask.distributed Client (otherwise one is made from plan.scheduler or
    a LocalCluster with plan.workers processes, threads if ``processes`` is False).
    ``threads``: threads of each run (default: cores / workers for the sweep's own
    LocalCluster, else all cores); never changes the fields. ``memory_bytes``: memory budget of each
    run (`turbgen sweep --memory`): Mann runs that do not fit are made out of core (the same fields).
    Raises SweepLockedError (before touching anything) when another sweep holds DIR.
    """
    t_start = time.perf_counter()
    out = plan.out
    _check_out(out)
    with exit_on_signals(), SweepLock(out):
        previous = {r.get("name"): r for r in (read_manifest(out) or {}).get("runs", []) if isinstance(r, dict)}
        report_removed(remove_dead_temps(out, [pr.store_name for pr in plan.runs]))
        records = {pr.name: _base_record(pr) for pr in plan.runs}
        tasks: dict[str, RunTask] = {}
        skipped = 0
        states = {pr.name: store_state(out / pr.store_name, pr) for pr in plan.runs}
        mismatched = [detail for state, detail in states.values() if state == "mismatch"]
        if mismatched:
            more = f" (and {len(mismatched) - 1} more)" if len(mismatched) > 1 else ""
            raise ParameterError(f"{out}: {mismatched[0]}{more}; nothing run, manifest unchanged: "
                                 "use another --out for another grid or other parameters")
        rechunked = [pr.store_name for pr in plan.runs if states[pr.name][0] == "complete" and plan.chunk_t
                     and open_store(out / pr.store_name).chunk_t != plan.chunk_t]
        if rechunked:
            print(f"kept {len(rechunked)} existing store(s) ({rechunked[0]}, ...) with time chunks other than "
                  f"--chunks {plan.chunk_t} (the field does not depend on chunking; delete them to rechunk)",
                  file=sys.stderr)
        for pr in plan.runs:
            rec = records[pr.name]
            path = out / pr.store_name
            state, detail = states[pr.name]
            if state == "complete":
                skipped += 1
                old = previous.get(pr.name, {})
                same = old.get("status") == "complete" and old.get("path") == pr.store_name and old.get("checksum")
                if same:
                    for k in ("duration_s", "checksum", "sigma_m_s", "validation", "lidar", "finished_utc"):
                        rec[k] = old.get(k)
                rec["action"] = "skipped"
                if same and (rec["validation"] is not None or not plan.validate) and (
                        rec.get("lidar") is not None or not plan.lidar):
                    rec["status"] = "complete"
                    continue
                tasks[pr.name] = RunTask(pr.model, pr.run, str(path), False, plan.chunk_t, plan.validate, False,
                                         lidar=plan.lidar)
                continue
            tasks[pr.name] = RunTask(pr.model, pr.run, str(path), state == "incomplete", plan.chunk_t, plan.validate,
                                     lidar=plan.lidar)
        need = sum(3 * t.run.grid.nbytes_per_component() for t in tasks.values() if t.generate)
        if need:
            n_gen = sum(t.generate for t in tasks.values())
            require_disk(out, need, f"the {n_gen} stores still to generate", "free space, choose another --out "
                         "or sweep fewer seeds/speeds or a smaller grid")
        sweep_doc = plan.to_dict()
        # runs of earlier sweeps into DIR that this plan does not contain keep their records
        earlier = [r for name, r in previous.items() if name not in records]

        def save():
            write_manifest(out, sweep_doc, [*records.values(), *earlier])

        save()
        result = SweepResult(out, list(records.values()), skipped=skipped)
        if tasks:
            if memory_bytes is not None:
                tasks = {name: replace(t, memory_bytes=memory_bytes) for name, t in tasks.items()}
            try:
                _execute(plan, tasks, records, save, result, client, processes, progress, threads)
            except (KeyboardInterrupt, SystemExit):
                _settle_interrupted(plan, records)
                save()
                raise
        result.records = list(records.values())
        result.failed = [r["name"] for r in result.records if r["status"] != "complete"]
        result.seconds = round(time.perf_counter() - t_start, 3)
        save()
    return result


def _execute(plan, tasks, records, save, result, client, processes, progress, threads):
    from distributed import as_completed
    from tqdm import tqdm

    own_client = cluster = None
    if client is None:
        n = plan.workers or default_workers(tasks.values())
        own_client, cluster = _make_client(plan, n, processes)
        client = own_client
        if cluster is not None and threads is None:  # share the cores between the local workers' FFTs
            threads = max(1, (os.cpu_count() or 1) // n)
    if threads is not None:
        tasks = {name: replace(t, threads=threads) for name, t in tasks.items()}
    try:
        by_name = {pr.name: pr for pr in plan.runs}
        stencils: dict = {}  # shared_stencil_key -> [unit stencil future, runs still to use it]
        futures = {}  # future key -> (run name, stencil key or None)
        pending = []
        for name, task in tasks.items():
            stencil = None
            if task.model == "mann" and task.generate and not _out_of_core(task):
                from turbgen.runs.stencil_cache import build_shared_stencil, shared_stencil_key

                key = shared_stencil_key(by_name[name].run)
                if key not in stencils:  # the ae-free stencil: shared also by runs differing in TI or class
                    stencils[key] = [client.submit(build_shared_stencil, by_name[name].run, pure=False,
                                                   key=f"build_mann_stencil-{os.urandom(4).hex()}"), 0]  # fmt: skip
                stencils[key][1] += 1
                stencil = stencils[key][0]
            fut = client.submit(execute_run, task, stencil, pure=False, key=f"turbgen-run-{name}-{os.urandom(4).hex()}")
            pending.append(fut)
            futures[fut.key] = (name, key if stencil is not None else None)
        bar = tqdm(total=len(pending), desc="sweep", unit="field", file=sys.stderr,
                   disable=not (progress and sys.stderr.isatty()))  # fmt: skip
        with bar:
            for fut in as_completed(pending):
                name, skey = futures[fut.key]
                if fut.status == "finished":
                    res = fut.result()
                else:  # the stencil task (or the worker) failed: same error for each of its runs
                    res = {"status": "failed", "error": _one_line(fut.exception()), "duration_s": None}
                fut.release()
                if skey is not None:
                    stencils[skey][1] -= 1
                    if stencils[skey][1] == 0:
                        stencils.pop(skey)[0].release()
                rec = records[name]
                rec.update(res)
                rec["finished_utc"] = utc_now()
                if tasks[name].generate:
                    rec["action"] = "ran"
                    if rec["status"] == "complete":
                        result.ran += 1
                save()
                bar.set_postfix_str(f"{name}: {rec['status']}", refresh=False)
                bar.update(1)
    except (KeyboardInterrupt, SystemExit):
        # shutting the cluster down mid-run makes the scheduler log lost comms at CRITICAL level
        logging.getLogger("distributed").setLevel(logging.CRITICAL + 1)
        raise
    finally:
        if own_client is not None:
            own_client.close()
        if cluster is not None:
            cluster.close()


def summary_table(result: SweepResult) -> str:
    """Plain-text table of every run (name, status, action, seconds, sigma_u, validation, error)."""
    rows = [("run", "status", "action", "seconds", "sigma_u", "validation", "error")]
    for r in result.records:
        sig = r.get("sigma_m_s") or [None]
        val = r.get("validation")
        rows.append(
            (
                r["name"],
                r["status"],
                r["action"],
                "" if r.get("duration_s") is None else f"{r['duration_s']:.1f}",
                "" if sig[0] is None else f"{sig[0]:.3f}",
                "" if val is None else ("pass" if val.get("passed") else "FAIL"),
                (r.get("error") or "")[:70],
            )
        )
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    n_ok = sum(r["status"] == "complete" for r in result.records)
    lines.append(
        f"{n_ok}/{len(result.records)} complete ({result.ran} generated, {result.skipped} already there), "
        f"{len(result.failed)} failed or pending, {result.seconds:.1f} s -> {result.out}"
    )
    if result.validation_failed:
        lines.append(f"validation failed for {len(result.validation_failed)}: {', '.join(result.validation_failed)}")
    lidar = [r["lidar"] for r in result.records if r.get("lidar") and "simulated" in r["lidar"]]
    if lidar:
        k05 = np.array([d["simulated"].get("k05_rad_m") or np.nan for d in lidar], dtype=float)
        fc = np.array([d["simulated"].get("cutoff_hz") or np.nan for d in lidar], dtype=float)
        th = lidar[0]["theory"]
        lines.append(f"lidar over {len(lidar)} fields: k_0.5 {np.nanmean(k05):.4f} +- {np.nanstd(k05):.4f} rad/m "
                     f"(theory {th.get('k05_rad_m') or float('nan'):.4f}), cut-off {np.nanmean(fc):.4f} +- "
                     f"{np.nanstd(fc):.4f} Hz (theory {th.get('cutoff_hz') or float('nan'):.4f})")
    if result.lidar_failed:
        lines.append(f"lidar coherence failed for {len(result.lidar_failed)}: {', '.join(result.lidar_failed)}")
    return "\n".join(lines)
