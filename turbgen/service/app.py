"""The ASGI application of `turbgen serve` (FastAPI): the routers of turbgen.service.routes over one
:class:`~turbgen.service.state.ServiceState`, with the service's error format and Host check.

Every path component a client sends is either a run id (24 hex digits, checked before any disk
access) or matched against names the server itself listed; anything else is 404."""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from turbgen.version import __version__
from turbgen.errors import TurbgenError
from turbgen.service.catalog import Catalog
from turbgen.service.cleanup import DEFAULT_STENCIL_CACHE_BYTES, remove_dead_work, trim_stencil_cache
from turbgen.service.jobs import Jobs
from turbgen.service.limits import DERIVED_RUNNING, DERIVED_WAITING, LimitError, is_loopback
from turbgen.service.routes import constraints, field, pages, products, runs, sweeps
from turbgen.service.state import ServiceSettings, ServiceState
from turbgen.service.status import public_text


def _error(status: int, message: str, headers: dict | None = None) -> JSONResponse:
    return JSONResponse({"detail": message}, status_code=status, headers=headers)


def create_app(root: Path, client, *, token: str | None = None, memory_budget: int, max_queue: int,
               loopback_only: bool = False, stencil_cache_bytes: int | None = DEFAULT_STENCIL_CACHE_BYTES,
               own_cluster: bool = True, derived_running: int = DERIVED_RUNNING,
               derived_waiting: int = DERIVED_WAITING) -> FastAPI:
    """The application over the catalog in ``root`` running jobs on the dask ``client`` (the other parameters:
    :class:`~turbgen.service.state.ServiceSettings`'); ``app.state`` holds ``service``, ``jobs`` and ``removed``."""
    settings = ServiceSettings(Path(root), token, memory_budget, max_queue, loopback_only, derived_running,
                               derived_waiting, stencil_cache_bytes, own_cluster)  # fmt: skip
    catalog = Catalog(settings.root)
    state = ServiceState(settings, catalog, Jobs(catalog, client, max_queue, stencil_cache_bytes))
    app = FastAPI(title="turbgen serve", version=__version__, docs_url=None, redoc_url=None,  # they load from a CDN
                  description="Turbulence fields on demand: the same runs as `turbgen mann|kaimal`, deduplicated.")
    # /docs is the service's own page (routes.pages), rendered from /openapi.json without any external host
    app.state.service = state
    app.state.jobs = state.jobs
    app.state.removed = remove_dead_work(catalog, stencils=own_cluster)
    app.state.removed += trim_stencil_cache(settings.root / "stencils", stencil_cache_bytes)
    _add_error_handlers(app)
    if loopback_only:
        app.middleware("http")(_loopback_host)
    for module in (pages, runs, sweeps, products, field, constraints):
        app.include_router(module.router)
    return app


async def _loopback_host(request: Request, call_next):
    """400 unless the Host header names a loopback address (DNS rebinding)."""
    host = request.headers.get("host", "")
    name = host[1:host.find("]")] if host.startswith("[") else host.rsplit(":", 1)[0]
    if not is_loopback(name.lower()):  # host names are case-insensitive
        return _error(400, f"Host {host!r} is not a loopback name of this server")
    return await call_next(request)


def _add_error_handlers(app: FastAPI) -> None:
    """Every error as one JSON line ``{"detail": "..."}``: FastAPI's parameter checks, limits, turbgen errors."""

    @app.exception_handler(RequestValidationError)
    async def _invalid(request, exc: RequestValidationError):
        # FastAPI's own check of query and path parameters (e.g. ?U=fast): one line as every other error
        parts = [f"{'.'.join(str(x) for x in e.get('loc', ()))}: {e.get('msg', 'invalid')}" for e in exc.errors()]
        return _error(422, "; ".join(parts) or "invalid request")

    @app.exception_handler(LimitError)
    async def _limit(request, exc: LimitError):
        return _error(exc.status, str(exc), exc.headers)

    @app.exception_handler(TurbgenError)
    async def _param(request, exc: TurbgenError):
        return _error(422, public_text(str(exc), request.app.state.service.catalog))
