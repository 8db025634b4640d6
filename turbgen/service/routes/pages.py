"""The web page at / and the health check."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request
from fastapi.responses import HTMLResponse

from turbgen.version import __version__
from turbgen.service.pages import api_docs_html, index_html
from turbgen.service.state import ServiceState, get_state

router = APIRouter()


@router.get("/", response_class=HTMLResponse, include_in_schema=False)
def index(state: ServiceState = Depends(get_state)):
    """The catalog page with its submit form."""
    return HTMLResponse(index_html(token_required=state.settings.token is not None))


@router.get("/docs", response_class=HTMLResponse, include_in_schema=False)
def docs(request: Request):
    """The API reference, rendered here from /openapi.json (FastAPI's Swagger UI is off: it loads from a CDN)."""
    return HTMLResponse(api_docs_html(request.app.openapi()))


@router.get("/health")
async def health(state: ServiceState = Depends(get_state)):
    """Liveness: the version, the runs queued or running, and the computations started since start-up.

    A coroutine on the event loop: it needs no worker thread, so it answers while every thread computes.
    """
    with state.jobs.lock:
        active = len(state.jobs.active)
    return {"ok": True, "turbgen": __version__, "active": active, "computations": state.jobs.computations}
