"""The request-body timer counts the client's time, not the server's (issue 37: under a cold start with load, 25 of
60 simultaneous identical POSTs got ``408 request body not received within 10 s`` though each client had sent its
small body at once). Loopback only; bounded counts and times."""

from __future__ import annotations

import asyncio
import http.client
import json
import threading
import time

import pytest

from service_server import TINY_GRID
from turbgen.service import bodies
from turbgen.service.limits import LimitError


class _Request:
    """What _bounded_body uses of a starlette Request: headers and a stream of one chunk, readable from ``ready``."""

    def __init__(self, ready: asyncio.Event):
        self.headers = {"content-length": "2"}
        self.ready = ready

    async def stream(self):
        await self.ready.wait()
        for _ in range(5):  # the loop passes of the middleware's receive wrapper (anyio task group) after the data
            await asyncio.sleep(0)
        yield b"{}"


def _read_with_stalled_loop(arrives_s: float | None, stall_s: float) -> bytes:
    """Read a body whose chunk arrives after ``arrives_s`` (None: never) while the event loop is blocked by the
    server's own work for ``stall_s`` from the start, past the 0.2 s body deadline."""
    async def main():
        ready = asyncio.Event()
        loop = asyncio.get_running_loop()
        if arrives_s is not None:
            loop.call_later(arrives_s, ready.set)
        loop.call_later(0.01, time.sleep, stall_s)  # a synchronous handler holding the loop
        return await bodies._bounded_body(_Request(ready), 100)

    return asyncio.run(main())


def test_a_body_that_arrived_while_the_server_was_busy_is_read(monkeypatch):
    # the chunk arrives at 0.05 s, the deadline is 0.2 s, the loop is blocked from 0.01 s to 0.51 s: when the loop
    # runs again both are due, and the read needs a few more loop passes; asyncio.wait_for cancelled it (the old 408)
    monkeypatch.setattr(bodies, "BODY_TIMEOUT_S", 0.2)
    assert _read_with_stalled_loop(0.05, 0.5) == b"{}"


def test_a_body_the_client_never_sends_is_still_408(monkeypatch):
    monkeypatch.setattr(bodies, "BODY_TIMEOUT_S", 0.2)
    t0 = time.monotonic()
    with pytest.raises(LimitError) as err:
        _read_with_stalled_loop(None, 0.0)
    assert err.value.status == 408 and time.monotonic() - t0 < 2.0


def _post(port: int, body: bytes, out: list) -> None:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=120)
    try:
        conn.request("POST", "/runs", body, {"Content-Type": "application/json"})
        response = conn.getresponse()
        out.append((response.status, response.read()[:200]))
    finally:
        conn.close()


def test_simultaneous_identical_posts_during_slow_run_building_get_no_408(tmp_path, monkeypatch):
    """12 clients POST the same small body, 0.1 s apart, while building each run takes 1 s of synchronous work (a
    cold start's energy-level quadrature and compilation); the body deadline is 1 s. Every POST is accepted, and the
    server answers another request meanwhile: the builds run in threads, not on the event loop, where they held
    every other request (and their body timers, issue 37)."""
    from inprocess_server import InProcessServer

    from turbgen.service.routes import runs

    real_build = runs.build_run

    def slow_build(body):
        time.sleep(1.0)
        return real_build(body)

    monkeypatch.setattr(runs, "build_run", slow_build)
    monkeypatch.setattr(bodies, "BODY_TIMEOUT_S", 1.0)
    body = json.dumps({"model": "kaimal", "seed": 3, "U_m_s": 10.0, "grid": dict(TINY_GRID)}).encode()
    srv = InProcessServer(tmp_path / "root")
    try:
        results: list = []
        threads = [threading.Thread(target=_post, args=(srv.port, body, results)) for _ in range(12)]
        for t in threads:  # arriving one by one while earlier requests build their runs, as clients do
            t.start()
            time.sleep(0.1)
        t0 = time.monotonic()
        conn = http.client.HTTPConnection("127.0.0.1", srv.port, timeout=60)
        conn.request("GET", "/health")
        assert conn.getresponse().status == 200
        conn.close()
        # the loop answers while the builds run in threads (on the loop, each queued 1 s build held it)
        assert time.monotonic() - t0 < 0.8
        for t in threads:
            t.join(timeout=120)
        assert len(results) == 12, results
        assert sorted({status for status, _ in results}) in ([200, 202], [202]), results
    finally:
        srv.stop()
