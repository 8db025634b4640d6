"""Execute a sweep plan on dask.distributed: resumable, idempotent, one lock per output directory (docs/sweep.md).

A LocalCluster sized to the machine (:func:`default_workers`) or an existing scheduler; parts shared between runs
(a Mann stencil) built once as tasks. Every planned store is inspected first: complete ones kept, incomplete ones
regenerated, one with other parameters refuses the sweep before anything is written. Failing runs are recorded, the
manifest rewritten after each run. On Ctrl-C, SIGTERM, SIGHUP the manifest is saved and the interruption propagates."""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

from turbgen import fft
from turbgen.errors import ParameterError, one_line
from turbgen.interruption import exit_on_signals
from turbgen.resources import require_disk
from turbgen.runs.models import MODELS
from turbgen.store import open_store
from turbgen.store.temporaries import report_removed
from turbgen.sweep.lock import SweepLock
from turbgen.sweep.manifest import read_manifest, utc_now, write_manifest
from turbgen.sweep.plan import SweepPlan, check_memory_budget
from turbgen.sweep.result import SweepResult, summary_table
from turbgen.sweep.state import base_record, remove_dead_temps, store_state
from turbgen.sweep.tasks import RunTask, default_workers, execute_run

__all__ = ["SweepResult", "run_sweep", "summary_table"]


@contextlib.contextmanager
def _own_client(plan: SweepPlan, n: int, processes: bool):
    """The sweep's own (client, cluster) for the block (cluster None with plan.scheduler), closed after it. Its
    worker processes that outlive the close (one that failed or timed out under load) are killed: they ignore
    SIGTERM, so the interpreter's exit, which terminates and joins its children, would wait for them forever."""
    from distributed import Client

    from turbgen.runs.local_cluster import loopback_cluster

    deferring = processes and not plan.scheduler and threading.current_thread() is threading.main_thread()
    if deferring:
        # multiprocessing's resource tracker (a helper process) masks SIGINT/SIGTERM but not SIGHUP:
        # start it with SIGHUP ignored so a hang-up does not kill it (tracebacks on relaunch)
        from multiprocessing import resource_tracker

        old = signal.signal(signal.SIGHUP, signal.SIG_IGN)
        try:
            resource_tracker.ensure_running()
        finally:
            signal.signal(signal.SIGHUP, old)
    client = cluster = None
    pids: set[int] = set()  # the workers' (other sweeps of this process keep theirs)
    # a terminal's Ctrl-C goes to the whole process group: only the sweep may see it (it shuts the workers down).
    # The signals stay blocked until the workers ignore them (a worker inherits the starting thread's mask); one
    # that came meanwhile is raised when they are unblocked, with the cluster up and then closed in order. The mask
    # is the main thread's only: another thread (a BLAS or pool thread made earlier) may take the signal, and Python
    # then runs its handler in the main thread at once, inside distributed's start-up, which may swallow it (a sweep
    # interrupted so ran to its end) — so the start-up's handlers only record it, and it is raised after them.
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, DEFERRED_SIGNALS) if deferring else None
    caught: list[int] = []
    handlers = {s: h for s in DEFERRED_SIGNALS if deferring and (h := signal.getsignal(s)) is not None}  # not C's
    for sig in handlers:
        signal.signal(sig, lambda signum, _: caught.append(signum))
    try:
        try:
            cluster = None if plan.scheduler else loopback_cluster(n, 1, processes)
            client = Client(plan.scheduler or cluster)
            if processes and cluster is not None:
                pids = set(client.run(_ignore_interrupts).values())
        finally:
            for sig, handler in handlers.items():
                signal.signal(sig, handler)
            if mask is not None:
                signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # raises a signal that came during the start-up
            if caught:
                signal.raise_signal(caught[0])  # one that another thread took meanwhile
        yield client, cluster
    finally:
        try:
            close_quietly(client, cluster, quiet=isinstance(sys.exc_info()[1], (KeyboardInterrupt, SystemExit)))
        finally:
            for child in multiprocessing.active_children():
                if child.pid in pids:
                    child.kill()
                    child.join(10)


DEFERRED_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def _ignore_interrupts() -> int:
    """Worker side: ignore SIGINT, SIGTERM and SIGHUP (the sweep closes the workers) and drop the heartbeat
    failure traceback at shutdown; return the worker's process id."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_IGN)
    heartbeat = "Failed to communicate with scheduler during heartbeat"  # the closing scheduler's
    logging.getLogger("distributed.worker").addFilter(lambda record: not str(record.msg).startswith(heartbeat))
    return os.getpid()


def _check_out(out: Path) -> None:
    """One-line errors for an --out that cannot hold a sweep (a file, under a file, read-only)."""
    if out.exists() and not out.is_dir():
        raise ParameterError(f"`out` {out} is a file, not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError(f"`out` {out} cannot be created: {exc.strerror} ({exc.filename})") from None
    if not os.access(out, os.W_OK):
        raise ParameterError(f"`out` {out} is not writable")


def _settle_interrupted(plan: SweepPlan, records: dict) -> None:
    """After an interruption: record as complete the pending runs whose store a worker completed."""
    for pr in plan.runs:
        if (rec := records[pr.name])["status"] != "pending":
            continue
        state, _ = store_state(plan.out / pr.store_name, pr)
        if state == "complete":  # checksum left empty: the next run of the sweep fills it in
            rec.update(status="complete", action="ran", error=None, finished_utc=utc_now())
        else:
            rec["error"] = "interrupted before this run finished"


def _check_states(plan: SweepPlan, states: dict) -> None:
    """Refuse a sweep into stores of other parameters; say which complete stores keep other time chunks."""
    mismatched = [detail for state, detail in states.values() if state == "mismatch"]
    if mismatched:
        more = f" (and {len(mismatched) - 1} more)" if len(mismatched) > 1 else ""
        raise ParameterError(f"{plan.out}: {mismatched[0]}{more}; nothing run, manifest unchanged: "
                             "use another `out` for another grid or other parameters")
    rechunked = [pr.store_name for pr in plan.runs if states[pr.name][0] == "complete" and plan.chunk_t
                 and open_store(plan.out / pr.store_name).chunk_t != plan.chunk_t]
    if rechunked:
        print(f"kept {len(rechunked)} existing store(s) ({rechunked[0]}, ...) with time chunks other than "
              f"--chunks {plan.chunk_t} (the field does not depend on chunking; delete them to rechunk)",
              file=sys.stderr)


def _tasks(plan: SweepPlan, states: dict, records: dict, previous: dict, stencil_cache) -> tuple[dict, int]:
    """The RunTasks still to do (generate, or validate / lidar a kept store) and the number of complete stores;
    a complete store keeps its previous record."""
    tasks: dict[str, RunTask] = {}
    skipped = 0
    for pr in plan.runs:
        rec, state = records[pr.name], states[pr.name][0]
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
        tasks[pr.name] = RunTask(pr.model, pr.run, str(plan.out / pr.store_name), state == "incomplete", plan.chunk_t,
                                 plan.validate, state != "complete", lidar=plan.lidar, constraints=plan.constraints,
                                 cache_dir=None if stencil_cache is None else os.fspath(stencil_cache))
    return tasks, skipped


def run_sweep(plan: SweepPlan, *, client=None, processes: bool = True, progress: bool = True,
              threads: int | None = None, memory_bytes: int | None = None,
              stencil_cache: str | os.PathLike | None = None) -> SweepResult:
    """Run every planned field that has no complete store yet; write DIR/manifest.{json,csv}; return the SweepResult
    (failing runs are recorded, not raised).

    ``client``: default from plan.scheduler, else a LocalCluster of plan.workers (processes unless ``processes`` is
    False). ``threads`` per run (default: cores / workers) never changes the fields. ``memory_bytes``: each run's
    budget [B] (Mann runs over it go out of core). ``stencil_cache``: seen by the workers at the same path.
    SweepLockedError when another sweep holds DIR; ParameterError if ``out`` cannot hold the sweep, a planned store
    has other parameters (nothing run) or the disk lacks space."""
    t_start = time.perf_counter()
    out = plan.out
    check_memory_budget(plan.runs, memory_bytes, plan.chunk_t)  # before DIR or its manifest is touched
    _check_out(out)
    with exit_on_signals(), SweepLock(out):
        previous = {r.get("name"): r for r in (read_manifest(out) or {}).get("runs", []) if isinstance(r, dict)}
        report_removed(remove_dead_temps(out, [pr.store_name for pr in plan.runs]))
        records = {pr.name: base_record(pr) for pr in plan.runs}
        states = {pr.name: store_state(out / pr.store_name, pr) for pr in plan.runs}
        _check_states(plan, states)
        tasks, skipped = _tasks(plan, states, records, previous, stencil_cache)
        need = sum(3 * t.run.grid.nbytes_per_component() for t in tasks.values() if t.generate)
        if need:
            require_disk(out, need, f"the {sum(t.generate for t in tasks.values())} stores still to generate",
                         "free space, choose another `out` or sweep fewer seeds/speeds or a smaller grid")
        if progress:  # after every refusal: a refused sweep prints only its error
            print(f"sweep: {len(plan.runs)} runs -> {out}", file=sys.stderr)
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
            try:  # on ``client``, else the sweep's own local cluster, closed after
                n = plan.workers or default_workers(tasks.values())
                own = contextlib.nullcontext((client, None)) if client is not None else _own_client(plan, n, processes)
                with own as (client, cluster):
                    if cluster is not None and threads is None:  # share the cores between the local workers' FFTs
                        threads = max(1, (os.cpu_count() or 1) // n)
                    _submit_all(plan, tasks, records, save, result, client, progress, threads)
            except (KeyboardInterrupt, SystemExit):
                _settle_interrupted(plan, records)
                save()
                raise
        result.records = list(records.values())
        result.failed = [r["name"] for r in result.records if r["status"] != "complete"]
        result.seconds = round(time.perf_counter() - t_start, 3)
        save()
    return result


def _submit_all(plan, tasks, records, save, result, client, progress, threads):
    """Run ``tasks`` on ``client`` (``threads`` each, and this process's FFT backend: workers do not see it)."""
    from distributed import as_completed
    from tqdm import tqdm

    backend = fft.current()
    tasks = {name: replace(t, threads=threads or t.threads, fft_backend=backend) for name, t in tasks.items()}
    by_name = {pr.name: pr for pr in plan.runs}
    shared: dict = {}  # shared key -> [future of the shared part, runs still to use it]
    futures = {}  # future key -> (run name, shared key or None)
    pending = []
    for name, task in tasks.items():
        part, skey = None, None
        # a constrained run builds its own stencil (turbgen.runs.constrain): no shared part
        build = (MODELS[task.model].shared_part(task.run, task.threads, task.memory_bytes)
                 if task.generate and task.constraints is None else None)  # fmt: skip
        if build is not None:
            skey = MODELS[task.model].shared_key(by_name[name].run)
            if skey not in shared:
                shared[skey] = [client.submit(build, by_name[name].run, pure=False,
                                              key=f"turbgen-shared-{task.model}-{os.urandom(4).hex()}"), 0]
            shared[skey][1] += 1
            part = shared[skey][0]
        fut = client.submit(execute_run, task, part, pure=False, key=f"turbgen-run-{name}-{os.urandom(4).hex()}")
        pending.append(fut)
        futures[fut.key] = (name, skey)
    bar = tqdm(total=len(pending), desc="sweep", unit="field", file=sys.stderr,
               disable=not (progress and sys.stderr.isatty()))  # fmt: skip
    with bar:
        for fut in as_completed(pending):
            name, skey = futures[fut.key]
            if fut.status == "finished":
                res = fut.result()
            else:  # the shared part's task (or the worker) failed: same error for each of its runs
                res = {"status": "failed", "error": one_line(fut.exception()), "duration_s": None}
            fut.release()
            if skey is not None:
                shared[skey][1] -= 1
                if shared[skey][1] == 0:
                    shared.pop(skey)[0].release()
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


def close_quietly(*closables, quiet: bool) -> None:
    """Close the sweep's own client and cluster. Shut down mid-run (``quiet``), the scheduler logs lost comms at
    CRITICAL level: the ``distributed`` and ``tornado.application`` loggers are silenced for the shutdown only (their
    levels restored after), and a close that fails (a timeout under load) does not replace the interruption."""
    logs = [logging.getLogger(name) for name in ("distributed", "tornado.application")]
    levels = [log.level for log in logs]
    if quiet:
        for log in logs:
            log.setLevel(logging.CRITICAL + 1)
    try:
        for c in closables:
            if c is not None:
                with contextlib.suppress(*((Exception,) if quiet else ())):
                    c.close()
    finally:
        for log, level in zip(logs, levels):
            log.setLevel(level)
