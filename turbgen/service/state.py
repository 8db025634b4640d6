"""What every route of `turbgen serve` shares (settings, catalog, jobs, locks) and the FastAPI dependencies that
hand it to them (``Depends(get_state)``, ``Depends(require_token)``)."""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from pathlib import Path

from fastapi import Depends, Request

from turbgen.service.catalog import Catalog
from turbgen.service.jobs import Jobs
from turbgen.service.limits import (DERIVED_RUNNING, DERIVED_WAITING, DerivedLimiter, LimitError,
                                    check_token)  # fmt: skip


@dataclass(frozen=True)
class ServiceSettings:
    """The server's settings (command-line options of `turbgen serve`)."""

    root: Path  # the catalog's directory
    token: str | None  # of mutating requests and new computations (None: open)
    memory_budget_bytes: int  # largest run estimate [bytes] (413 above)
    max_queue: int  # runs queued or running (429 above)
    loopback_only: bool = False  # answer only a loopback Host header (400 otherwise: no DNS rebinding)
    derived_running: int = DERIVED_RUNNING  # products computed at once (503 beyond)
    derived_waiting: int = DERIVED_WAITING  # requests waiting for them (503 beyond)
    stencil_cache_bytes: int | None = None  # cap of ``root/stencils`` [bytes] (None: none)
    own_cluster: bool = True  # runs execute in this process (start-up may remove dead temporaries in root/stencils)


@dataclass
class ServiceState:
    """The server's shared state: settings, catalog, job queue, the bound on derived computations, per-key locks."""

    settings: ServiceSettings
    catalog: Catalog
    jobs: Jobs
    limiter: DerivedLimiter | None = None
    _locks: dict = field(default_factory=dict)
    _guard: threading.Lock = field(default_factory=threading.Lock)
    _generations: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.limiter is None:
            self.limiter = DerivedLimiter(self.settings.derived_running, self.settings.derived_waiting)

    def generation(self, rid: str) -> int:
        """How often run ``rid`` was deleted since start-up (a product computed across a change is not published)."""
        with self._guard:
            return self._generations.get(rid, 0)

    def deleted(self, rid: str) -> None:
        """Record that run ``rid`` is being deleted (call it holding ``lock_for(rid)``)."""
        with self._guard:
            self._generations[rid] = self._generations.get(rid, 0) + 1

    def lock_for(self, key: str) -> threading.Lock:
        """The lock of ``key`` (a run id, or a product such as ``<id>/validation``) for the server's lifetime."""
        with self._guard:
            return self._locks.setdefault(key, threading.Lock())


def get_state(request: Request) -> ServiceState:
    """FastAPI dependency: the application's :class:`ServiceState`."""
    return request.app.state.service


def require_token(request: Request, state: ServiceState = Depends(get_state)) -> None:
    """FastAPI dependency: LimitError 401 unless the request carries the server's bearer token (if it has one):
    mutating and computing requests need it, reading what exists does not."""
    check_token(state.settings.token, request.headers.get("authorization"))


def not_found() -> LimitError:
    """The one 404 of the service (never says which of run or file is missing)."""
    return LimitError(404, "no such run or file")


def complete_store(rid: str, state: ServiceState = Depends(get_state)) -> Path:
    """FastAPI dependency: the server path of run ``rid``'s store when it exists and is complete (LimitError 404 otherwise)."""
    if not state.catalog.exists(rid) or not state.catalog.is_complete(rid):
        raise not_found()
    return state.catalog.store_path(rid)
