"""The service's job queue on dask.distributed: one computation per run id, joined by duplicates.

A duplicate request for a queued or running id joins it; a complete store is never recomputed. After a restart,
``resume`` re-queues every recorded run with neither a complete store nor a failure, unless started MAX_STARTS times."""

from __future__ import annotations

import threading
import uuid
from pathlib import Path

from turbgen.errors import one_line
from turbgen.service.catalog import FAILURE_ROOM, Catalog, write_json_atomic
from turbgen.service.limits import RETRY_AFTER_S, LimitError
from turbgen.service.run_ids import canonical_mapping, replay_mapping, run_from_canonical
from turbgen.spec.constraints import ConstraintRequest

MAX_STARTS = 3  # a run started this often without finishing (its server died each time) is failed, not re-queued
_STENCIL_LOCK = threading.Lock()  # one stencil build at a time: a second request for it waits and reuses it


def execute(model: str, run, out: str, stencil_cache: str, stencil_cache_bytes: int | None = None,
            constraints: ConstraintRequest | None = None, energy_from_data: bool = False,
            replay: dict | None = None, fitted: tuple | None = None) -> dict:
    """Worker side: generate ``run`` of ``model`` into the store ``out`` as the CLI does; the run summary's
    JSON-able entries. Mann stencils: one build at a time per process, cached in ``stencil_cache`` (capped at
    ``stencil_cache_bytes``). ``constraints``: files to condition on (ae from them with ``energy_from_data``);
    ``replay``: the run mapping the fit to them completes (``turbgen mann --fit``), the fitted keys in ``fit``;
    ``fitted``: that fit when the submission made it (turbgen.runs.replay.fitted_inputs), None: fitted here."""
    from turbgen.runs.models import get_model

    if constraints is not None:
        from turbgen.runs.constrain import (describe_constraints, load_constraints, run_mann_constrained,
                                            with_energy_from_data)  # fmt: skip
        from turbgen.runs.replay import describe_fit, fitted_inputs

        files, fit = load_constraints(constraints.files), None
        if replay is not None:
            fitted = fitted or fitted_inputs(replay, files, evo_typed="evo_time_s" in replay)
            mapping, files, fit = fitted
            run = with_energy_from_data(mapping, files, constraints.noise_m_s)  # ae fitted: the run of mapping
        elif energy_from_data:
            mapping = {k: v for k, v in canonical_mapping(run).items() if k not in ("ae", "ae_from")}
            run = with_energy_from_data(mapping, files, constraints.noise_m_s, stencil_cache)
        summary = run_mann_constrained(run, out, files, noise_m_s=constraints.noise_m_s,
                                       conditional_mean=constraints.conditional_mean, cache_dir=stencil_cache, fit=fit)
        notes = describe_constraints(summary["constraints"])  # as `turbgen mann --constrain [--fit]` prints, fit first
        return _scalars(summary) | ({"conditioning": notes} if fit is None else
                                    {"conditioning": describe_fit(fit) + notes, "fit": fit["run"]})
    entry = get_model(model)
    build_shared = entry.shared_part(run, None, None)
    shared = None
    if build_shared is not None:
        from turbgen.service.cleanup import trim_stencil_cache

        with _STENCIL_LOCK:
            shared = build_shared(run, stencil_cache)
            trim_stencil_cache(Path(stencil_cache), stencil_cache_bytes)  # the entry just used is the most recent
    return _scalars(entry.run(run, out, shared=shared))


def _scalars(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if isinstance(v, (int, float, str, bool, list)) and k != "path"}


class Jobs:
    """Submitted runs by id (queued or running) on the dask ``client``, at most ``max_queue`` at once;
    ``stencil_cache_bytes`` caps the stencil cache ``root/stencils`` [bytes] (None: no cap)."""

    def __init__(self, catalog: Catalog, client, max_queue: int, stencil_cache_bytes: int | None = None):
        self.catalog = catalog
        self.client = client
        self.max_queue = max_queue
        self.stencil_cache_bytes = stencil_cache_bytes
        self.lock = threading.Lock()
        self.active: dict[str, object] = {}
        self.computations = 0  # runs handed to dask since start (duplicates are joined, not counted)

    def submit(self, rid: str, model: str, run, preset: str | None = None, constraints: dict | None = None,
               fitted: tuple | None = None) -> str:
        """Submit run ``rid`` (``preset``: a label; ``constraints``: upload keys; ``fitted``: a replay's fit, see
        :func:`execute`) unless complete or active: "complete", "joined" or "queued". LimitError 429 at
        ``max_queue`` runs, 507 when the run cannot be recorded (disk full)."""
        with self.lock:
            if rid in self.active:
                return "joined"
            if self.catalog.is_complete(rid):
                return "complete"
            # a run whose store is published holds no place while its worker's result comes back (the client
            # already sees it complete and may submit the next)
            busy = self.busy()
            if busy >= self.max_queue:
                raise LimitError(429, f"{busy} runs are queued or running (the server's --max-queue)",
                                 {"Retry-After": str(RETRY_AFTER_S)})  # fmt: skip
            try:
                self.catalog.record(rid, model, canonical_mapping(run, constraints), preset)
            except OSError as exc:  # nothing queued: the run could not even be recorded (a full or read-only disk)
                raise LimitError(507, f"the server cannot record the run ({exc.strerror or exc}); try later") from None
            self._start(rid, model, run, constraints, fitted)
            return "queued"

    def _start(self, rid: str, model: str, run, constraints: dict | None = None, fitted: tuple | None = None) -> None:
        self.catalog.clear_partial(rid)
        self.catalog.count_start(rid)
        out = str(self.catalog.store_path(rid))
        cache = str(self.catalog.root / "stencils")
        request = None
        if constraints:
            request = ConstraintRequest(tuple(str(p) for p in self.catalog.uploads.paths(constraints["constrain"])),
                                        constraints.get("noise_m_s"), constraints.get("conditional_mean", False))
        fut = self.client.submit(execute, model, run, out, cache, self.stencil_cache_bytes, request,
                                 bool(constraints and constraints.get("energy_from_data")),
                                 replay_mapping(run, constraints or {}), fitted,
                                 key=f"turbgen-run-{rid}-{uuid.uuid4().hex[:8]}", pure=False)  # fmt: skip
        self.active[rid] = fut
        self.computations += 1
        fut.add_done_callback(lambda f, rid=rid: self._finished(rid, f))

    def _finished(self, rid: str, fut) -> None:
        try:
            try:
                summary = fut.result()
                (self.catalog.run_dir(rid) / FAILURE_ROOM).unlink(missing_ok=True)  # a complete run needs none
                write_json_atomic(self.catalog.run_dir(rid) / "summary.json", summary)  # last: the run is done
            except Exception as exc:
                if not self.catalog.is_complete(rid):
                    self.catalog.mark_failed(rid, one_line(exc))
        except OSError:
            pass  # the run was deleted meanwhile
        finally:
            with self.lock:
                if self.active.get(rid) is fut:
                    del self.active[rid]

    def busy(self) -> int:
        """The active runs whose store is not published yet: the queue places taken (call with the lock held)."""
        return sum(not self.catalog.is_complete(r) for r in self.active)

    def is_active(self, rid: str) -> bool:
        """True while run ``rid`` is queued or running here."""
        with self.lock:
            return rid in self.active

    def cancel(self, rid: str) -> None:
        """Forget run ``rid`` and cancel its future (nothing if it is not active)."""
        with self.lock:
            fut = self.active.pop(rid, None)
        if fut is not None:
            fut.cancel()

    def resume(self) -> list[str]:
        """Re-queue recorded runs that are neither complete nor failed (after a crash or kill -9); their ids."""
        requeued = []
        for rid in self.catalog.ids():
            if self.catalog.is_complete(rid):
                self.catalog.clear_partial(rid)
                continue
            if self.catalog.failure(rid) is not None:
                continue
            if self.catalog.starts(rid) >= MAX_STARTS:
                self.catalog.mark_failed(rid, f"not re-queued: the server stopped while running it {MAX_STARTS} times "
                                              "(killed, out of memory or a full disk?); delete it to try again")
                continue
            try:
                req = self.catalog.request(rid)
                run, constraints = run_from_canonical(req["model"], req["run"])
                self.catalog.uploads.paths(constraints.get("constrain", ()))  # its data are still there
            except Exception as exc:  # an unreadable request is recorded as a failure, never retried blindly
                self.catalog.mark_failed(rid, f"cannot re-queue: {one_line(exc)}")
                continue
            with self.lock:
                self._start(rid, req["model"], run, constraints)
            requeued.append(rid)
        return requeued
