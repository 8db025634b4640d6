"""Routes of uploaded measurements (turbgen.service.uploads): upload one, describe one, delete one."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request
from fastapi.responses import JSONResponse
from starlette.concurrency import run_in_threadpool

from turbgen.service.bodies import read_upload
from turbgen.service.limits import LimitError
from turbgen.service.state import ServiceState, get_state, not_found, require_token
from turbgen.service.uploads import MAX_UPLOAD_BYTES, SUFFIXES, describe

router = APIRouter()


@router.post("/constraints", status_code=201, dependencies=[Depends(require_token)])
async def upload(request: Request, state: ServiceState = Depends(get_state)):
    """Upload the content of a point-series JSON (application/json) or CSV, or line-of-sight CSV (text/csv) file:
    its id (for a run's ``constrain``) and what it holds; 200 when the same content was uploaded before."""
    media, data = await read_upload(request, tuple(SUFFIXES), MAX_UPLOAD_BYTES)
    cid, info, new = await run_in_threadpool(state.catalog.uploads.add, media, data)
    return JSONResponse({"id": cid, **info}, status_code=201 if new else 200)


@router.get("/constraints/{cid}")
def get_upload(cid: str, state: ServiceState = Depends(get_state)):
    """What upload ``cid`` holds (kind, series, values, duration_s)."""
    try:
        path = state.catalog.uploads.path(cid)
    except KeyError:
        raise not_found() from None
    return {"id": cid, **describe(path)}


@router.delete("/constraints/{cid}", dependencies=[Depends(require_token)])
def delete_upload(cid: str, state: ServiceState = Depends(get_state)):
    """Remove upload ``cid`` (409 while a queued or running run is conditioned on it; finished runs keep their
    stores, which record the data as placed)."""
    try:
        path = state.catalog.uploads.path(cid)
    except KeyError:
        raise not_found() from None
    with state.jobs.lock:
        active = list(state.jobs.active)
    for rid in active:
        try:
            uses = cid in state.catalog.request(rid)["run"].get("constrain", ())
        except (OSError, ValueError, KeyError):
            continue
        if uses:
            raise LimitError(409, f"run {rid} is queued or running on these measurements; delete them once it has "
                             "finished")  # fmt: skip
    path.unlink(missing_ok=True)
    return {"id": cid, "deleted": True}
