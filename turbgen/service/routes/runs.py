"""Routes of single runs: submit, list, status, delete, and read-only zarr access to a complete store."""

from __future__ import annotations

import re
from datetime import datetime, timezone
from pathlib import Path

from fastapi import APIRouter, Depends, Request
from fastapi.responses import FileResponse, JSONResponse
from starlette.concurrency import run_in_threadpool

from turbgen.service.bodies import read_json
from turbgen.service.limits import LimitError, check_constrained_memory, check_memory
from turbgen.service.run_ids import build_run, canonical_mapping, check_replay, run_id
from turbgen.service.state import ServiceState, complete_store, get_state, not_found, require_token
from turbgen.service.status import run_status

router = APIRouter()
NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")  # a path component the server may look up


@router.post("/runs", status_code=202, dependencies=[Depends(require_token)])
async def submit(request: Request, state: ServiceState = Depends(get_state)):
    """Submit a run config (the JSON `turbgen mann|kaimal --config` takes, plus "model" and "preset"; a Mann run's
    ``constrain`` names measurements uploaded with POST /constraints by id)."""
    body = await read_json(request)
    # in a thread: building a run may compile (numba) and submitting writes; on the event loop it held every request
    rid, submitted = await run_in_threadpool(_accept, body, state)
    code = 200 if submitted == "complete" else 202
    return JSONResponse({"id": rid, "submitted": submitted, "status_url": f"/runs/{rid}",
                         "store_url": f"/runs/{rid}/store"}, status_code=code)


def _accept(body, state: ServiceState) -> tuple[str, str]:
    """Check and queue the run of a POST /runs body: (its id, how it was submitted)."""
    model, run, constraints = build_run(body)
    preset = body.get("preset") if isinstance(body, dict) else None
    rid, fitted = run_id(model, canonical_mapping(run, constraints)), None
    if constraints and not state.catalog.is_complete(rid):  # the data placed on the grid: refused before queueing
        files = [str(p) for p in state.catalog.uploads.paths(constraints["constrain"])]
        if "fit" in constraints and not state.jobs.is_active(rid):  # the fit's refusals before queueing
            fitted = check_replay(run, constraints, files)  # the worker takes it: one fit per replay
        check_constrained_memory(run, files, constraints, state.settings.memory_budget_bytes)
    elif not state.catalog.is_complete(rid):  # a complete run is served, never recomputed
        check_memory(model, run, state.settings.memory_budget_bytes)
    return rid, state.jobs.submit(rid, model, run, preset, constraints, fitted)


@router.get("/runs")
def list_runs(model: str | None = None, preset: str | None = None, U: float | None = None, seed: int | None = None,
              state: ServiceState = Depends(get_state)):  # fmt: skip
    """The catalog, newest first, optionally filtered by model, preset (as submitted), U [m/s] and seed: per run its
    status and progress, parameters, grid, submission time (``submitted_utc``) and, once complete, the store's size."""
    rows = []
    for rid in state.catalog.ids():
        try:
            s = run_status(state.catalog, state.jobs, rid)
            mtime = (state.catalog.run_dir(rid) / "request.json").stat().st_mtime
            submitted = datetime.fromtimestamp(mtime, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")
        except (OSError, ValueError, KeyError):
            continue
        p = s["parameters"]
        wanted = ((model is None or s["model"] == model) and (preset is None or s["preset"] == preset)
                  and (U is None or p.get("U_m_s") == U) and (seed is None or p.get("seed") == seed))
        if not wanted:
            continue
        rows.append({k: s.get(k) for k in ("id", "model", "status", "progress", "error", "parameters", "grid")} |
                    {"preset": s["preset"], "U_m_s": p.get("U_m_s"), "seed": p.get("seed"),
                     "submitted_utc": submitted, "size_bytes": _store_size(state, rid, s["status"])})  # fmt: skip
    rows.sort(key=lambda r: r["submitted_utc"], reverse=True)
    return {"runs": rows}


_SIZES: dict = {}  # (run id, the store's mtime) -> size [bytes]: a complete store never changes


def _store_size(state: ServiceState, rid: str, status: str) -> int | None:
    if status != "complete":
        return None
    store = state.catalog.store_path(rid)
    try:
        key = (rid, store.stat().st_mtime_ns)
        if key not in _SIZES:
            _SIZES[key] = sum(f.stat().st_size for f in store.rglob("*") if f.is_file())
    except OSError:
        return None
    return _SIZES[key]


@router.get("/runs/{rid}")
def get_run(rid: str, state: ServiceState = Depends(get_state)):
    """The status of run ``rid``: parameters, grid, status, progress, and its summary or error."""
    if not state.catalog.exists(rid):
        raise not_found()
    return run_status(state.catalog, state.jobs, rid)


@router.delete("/runs/{rid}", dependencies=[Depends(require_token)])
def delete_run(rid: str, state: ServiceState = Depends(get_state)):
    """Remove a finished run with its exports and validation (409 while it is queued or running)."""
    if not state.catalog.exists(rid):
        raise not_found()
    if state.jobs.is_active(rid):
        raise LimitError(409, "the run is queued or running; delete it once it has finished")
    with state.lock_for(rid):  # a derived product being computed is then not published (service.derived)
        state.deleted(rid)
        state.catalog.delete(rid)
    return {"id": rid, "deleted": True}


@router.api_route("/runs/{rid}/store/{path:path}", methods=["GET", "HEAD"])
def store_file(path: str, store: Path = Depends(complete_store)):
    """Read-only zarr access: xr.open_zarr("http://host:port/runs/<id>/store")."""
    parts = path.split("/")
    if not all(NAME.match(p) for p in parts):
        raise not_found()
    target = store.joinpath(*parts)
    try:
        target.resolve().relative_to(store.resolve())
    except ValueError:
        raise not_found() from None
    if not target.is_file():
        raise not_found()
    return FileResponse(target, media_type="application/octet-stream")
