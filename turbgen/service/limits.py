"""Request limits and authentication of `turbgen serve`: body size, memory budget, bearer token."""

from __future__ import annotations

import hmac
import ipaddress

from turbgen.resources import format_bytes

MAX_BODY_BYTES = 64 * 1024
DEFAULT_MEMORY_BUDGET_BYTES = 4 * 2**30
DEFAULT_MAX_QUEUE = 32
RETRY_AFTER_S = 5


class LimitError(Exception):
    """A request over a limit: HTTP ``status`` and a one-line message."""

    def __init__(self, status: int, message: str, headers: dict | None = None):
        super().__init__(message)
        self.status = status
        self.headers = headers or {}


def is_loopback(host: str) -> bool:
    """True for localhost and loopback addresses (127.0.0.0/8, ::1)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def read_token(path) -> str:
    """The bearer token in ``path`` (first line, stripped); ValueError if it is empty or too short."""
    with open(path) as f:
        token = f.readline().strip()
    if len(token) < 16:
        raise ValueError(f"token file {path}: the token must be at least 16 characters")
    return token


def check_token(expected: str | None, authorization: str | None) -> None:
    """LimitError 401 unless ``authorization`` is 'Bearer <expected>' (no token configured: open)."""
    if expected is None:
        return
    scheme, _, given = (authorization or "").partition(" ")
    if scheme.lower() != "bearer" or not hmac.compare_digest(given.strip().encode(), expected.encode()):
        raise LimitError(401, "this request needs the server's bearer token (Authorization: Bearer <token>)",
                         {"WWW-Authenticate": "Bearer"})  # fmt: skip


def run_memory_bytes(model: str, run) -> int:
    """Memory [bytes] the run allocates (the runs/ estimates the CLI checks before allocating)."""
    from turbgen.resources import default_threads
    from turbgen.runs.models import get_model

    return get_model(model).memory_bytes(run, default_threads(None))


def check_memory(model: str, run, budget_bytes: int) -> int:
    """LimitError 413 naming the estimate, the budget and what to change when the run does not fit."""
    from turbgen.runs.models import get_model

    need = run_memory_bytes(model, run)
    if need > budget_bytes:
        fields = get_model(model).memory_fields.replace("`", "")
        raise LimitError(413, f"grid: the run needs about {format_bytes(need)} of memory, over the server's budget of "
                         f"{format_bytes(budget_bytes)}; lower {fields} (or start the server with a larger "
                         "--memory-budget)")
    return need
