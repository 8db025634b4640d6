"""The web pages (the catalog with the run form at /, a run's page at /runs/<id>/view, their static files), what
the form is built from (/form.json, /form/request), the API reference at /docs and the health check."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request
from fastapi.responses import FileResponse, HTMLResponse

from turbgen.version import __version__
from turbgen.service.form import form_description
from turbgen.service.form_request import form_request
from turbgen.service.limits import check_memory
from turbgen.service.pages import STATIC, api_docs_html, page_html, static_files
from turbgen.service.routes.products import EXPORT_FORMATS
from turbgen.service.run_ids import build_run
from turbgen.service.state import ServiceState, get_state, not_found

router = APIRouter()
_MEDIA = {".js": "text/javascript; charset=utf-8", ".css": "text/css; charset=utf-8"}


@router.get("/", response_class=HTMLResponse, include_in_schema=False)
def index(state: ServiceState = Depends(get_state)):
    """The catalog page with the run form."""
    return HTMLResponse(page_html("index.html", form(state)))


@router.get("/runs/{rid}/view", response_class=HTMLResponse, include_in_schema=False)
def run_page(rid: str, state: ServiceState = Depends(get_state)):
    """The page of run ``rid``: its parameters, the field (time series, yz snapshots), exports, lidar, validation."""
    if not state.catalog.exists(rid):
        raise not_found()
    return HTMLResponse(page_html("run.html", form(state)))


@router.get("/static/{name}", include_in_schema=False)
def static(name: str):
    """A file of the pages (turbgen/service/static): only the names listed there."""
    if name not in static_files():
        raise not_found()
    return FileResponse(STATIC / name, media_type=_MEDIA[STATIC.joinpath(name).suffix])


@router.get("/form.json")
def form(state: ServiceState = Depends(get_state)):
    """What the run form is built from: per model its fields (the commands' option names, with the run-mapping key,
    group, kind, unit, allowed range, default and meaning), whether a token is needed, the export formats and the
    lidar presets."""
    from turbgen.virtual_lidar.description import PRESETS

    return form_description(token_required=state.settings.token is not None) | {
        "export_formats": list(EXPORT_FORMATS), "lidar_presets": list(PRESETS), "turbgen": __version__}


@router.get("/form/request")
def request_of_form(request: Request, state: ServiceState = Depends(get_state)):
    """The run form's values (``model`` and field name = text, as typed) checked as POST /runs checks them: the
    request body, the equivalent `turbgen` command and Python call; a 422 names the first bad field."""
    values = dict(request.query_params)
    model = values.pop("model", "mann")
    out = form_request(model, values)
    _, run, _ = build_run(out["body"])
    if "constrain" not in out["body"]:  # a constrained run's memory depends on its data: checked when submitted
        check_memory(model, run, state.settings.memory_budget_bytes)
    return out


@router.get("/docs", response_class=HTMLResponse, include_in_schema=False)
def docs(request: Request):
    """The API reference, rendered here from /openapi.json (FastAPI's Swagger UI is off: it loads from a CDN)."""
    return HTMLResponse(api_docs_html(request.app.openapi()))


@router.get("/health")
async def health(state: ServiceState = Depends(get_state)):
    """Liveness: the version, the runs queued or running, and the computations started since start-up (a coroutine:
    it answers while every worker thread computes)."""
    with state.jobs.lock:
        active = len(state.jobs.active)
    return {"ok": True, "turbgen": __version__, "active": active, "computations": state.jobs.computations}
