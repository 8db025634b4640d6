"""Request limits and authentication of `turbgen serve`: body size, memory budget, bearer token."""

from __future__ import annotations

import contextlib
import hmac
import ipaddress
import threading

from turbgen.input_files import TOKEN, read_input_text
from turbgen.spec.config import nested_deeper_than
from turbgen.resources import format_bytes

MAX_BODY_BYTES = 64 * 1024
MAX_JSON_DEPTH = 32  # nesting of a request body's arrays and objects (a run config needs 3)
DEFAULT_MEMORY_BUDGET_BYTES = 4 * 2**30
DEFAULT_MAX_QUEUE = 32
RETRY_AFTER_S = 5
DERIVED_RUNNING = 2  # exports, validations, lidar reports computed at once (each may take a core for a while)
DERIVED_WAITING = 8  # more requests waiting for one of them; beyond: 503 (the server's threads stay free)


class LimitError(Exception):
    """A request over a limit: HTTP ``status``, a one-line ``message`` and extra response ``headers``."""

    def __init__(self, status: int, message: str, headers: dict | None = None):
        super().__init__(message)
        self.status = status
        self.headers = headers or {}


def is_loopback(host: str) -> bool:
    """True for localhost and loopback addresses (127.0.0.0/8, ::1)."""
    try:
        return host == "localhost" or ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def read_token(path) -> str:
    """The bearer token in the file ``path`` (first line, stripped); ValueError if under 16 characters."""
    lines = read_input_text(path, TOKEN).splitlines()
    token = lines[0].strip() if lines else ""
    if len(token) < 16:
        raise ValueError(f"token file {path}: the token must be at least 16 characters")
    return token


def check_token(expected: str | None, authorization: str | None) -> None:
    """LimitError 401 unless ``authorization`` is 'Bearer <expected>' (``expected`` None: no token, all pass)."""
    if expected is None:
        return
    scheme, _, given = (authorization or "").partition(" ")
    if scheme.lower() != "bearer" or not hmac.compare_digest(given.strip().encode(), expected.encode()):
        raise LimitError(401, "this request needs the server's bearer token (Authorization: Bearer <token>)",
                         {"WWW-Authenticate": "Bearer"})  # fmt: skip


def check_memory(model: str, run, budget_bytes: int) -> int:
    """The run's estimated memory [bytes] with the default threads (the estimate the CLI checks too); LimitError 413
    if it exceeds ``budget_bytes``."""
    from turbgen.resources import default_threads
    from turbgen.runs.models import get_model

    need = get_model(model).memory_bytes(run, default_threads(None))
    _refuse_over_budget(need, budget_bytes, "the run", get_model(model).memory_fields.replace("`", ""))
    return need


def check_constrained_memory(run, files: list, constraints: dict, budget_bytes: int) -> int:
    """:func:`check_memory` for a constrained Mann ``run`` with the uploaded ``files`` placed on its grid."""
    from turbgen.resources import default_threads
    from turbgen.runs.constrain import constrained_memory_bytes, load_constraints, place

    placed = place(run, load_constraints(files), constraints.get("noise_m_s"))
    need = constrained_memory_bytes(run, placed, default_threads(None))
    _refuse_over_budget(need, budget_bytes, f"the constrained run ({placed.streams.n_streams} measurement streams)",
                        "nt, ny/nz or pad_yz, or measure fewer series")  # fmt: skip
    return need


def _refuse_over_budget(need: int, budget_bytes: int, what: str, lower: str) -> None:
    if need > budget_bytes:
        raise LimitError(413, f"grid: {what} needs about {format_bytes(need)} of memory, over the server's budget of "
                         f"{format_bytes(budget_bytes)}; lower {lower} (or start the server with a larger "
                         "--memory-budget)")  # fmt: skip


def check_json_depth(value, limit: int = MAX_JSON_DEPTH) -> None:
    """LimitError 422 if ``value`` (parsed JSON) nests arrays/objects deeper than ``limit`` (checked iteratively)."""
    if nested_deeper_than(value, limit):
        raise LimitError(422, f"request body: arrays and objects nested deeper than {limit} levels")


class DerivedLimiter:
    """At most ``running`` (>= 1) derived products computed at once and ``waiting`` (>= 0) more requests queued."""

    def __init__(self, running: int, waiting: int):
        self.running, self.waiting = running, waiting
        self._slots = threading.BoundedSemaphore(running)
        self._admitted = 0
        self._lock = threading.Lock()

    @contextlib.contextmanager
    def admit(self):
        """Admit the request for the block's duration; LimitError 503 when ``running + waiting`` are admitted."""
        with self._lock:
            if self._admitted >= self.running + self.waiting:
                raise LimitError(503, f"{self._admitted} exports, validations or lidar reports are being computed or "
                                 f"queued (at most {self.running} at once, {self.waiting} waiting); retry later",
                                 {"Retry-After": str(RETRY_AFTER_S)})  # fmt: skip
            self._admitted += 1
        try:
            yield
        finally:
            with self._lock:
                self._admitted -= 1

    @contextlib.contextmanager
    def slot(self):
        """Hold one of the ``running`` computation slots for the block's duration (waits for one)."""
        with self._slots:
            yield
