"""A real `turbgen serve` process on a free loopback port, for the service tests (always killed)."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request

TINY_GRID = {"nt": 256, "ny": 8, "nz": 8, "x_m": [0.0, 50.0]}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """``turbgen serve --root ROOT`` on 127.0.0.1; ``call`` speaks HTTP to it (urllib, no retries)."""

    def __init__(self, root, *args: str, timeout_s: float = 60.0):
        self.root = root
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        cmd = [sys.executable, "-c", "from turbgen.cli import main; main()", "serve", "--host", "127.0.0.1",
               "--port", str(self.port), "--root", str(root), *args]  # fmt: skip
        self.log = open(os.path.join(str(root) + ".log"), "ab")
        self.proc = subprocess.Popen(cmd, stdout=self.log, stderr=subprocess.STDOUT, env=os.environ.copy())
        deadline = time.monotonic() + timeout_s
        while True:
            if self.proc.poll() is not None:
                raise RuntimeError(f"turbgen serve exited with {self.proc.returncode}")
            try:
                if self.call("GET", "/health")[0] == 200:
                    break
            except OSError:
                pass
            if time.monotonic() > deadline:
                self.kill()
                raise RuntimeError("turbgen serve did not answer /health in time")
            time.sleep(0.2)

    def call(self, method: str, path: str, body=None, *, raw: bytes | None = None, headers: dict | None = None,
             timeout_s: float = 120.0):
        """(status, headers, parsed JSON or bytes) of one request (the default timeout leaves room for a first
        validation, which imports and compiles in a fresh server, on a loaded machine)."""
        data = raw if raw is not None else (None if body is None else json.dumps(body).encode())
        req = urllib.request.Request(self.url + path, data=data, method=method, headers=headers or {})
        if data is not None and not req.has_header("Content-type"):  # urllib keeps header names capitalize()d
            req.add_header("Content-Type", "application/json")
        try:
            with urllib.request.urlopen(req, timeout=timeout_s) as r:
                status, hdrs, payload = r.status, dict(r.headers), r.read()
        except urllib.error.HTTPError as e:
            status, hdrs, payload = e.code, dict(e.headers), e.read()
        if hdrs.get("content-type", "").startswith("application/json"):
            payload = json.loads(payload)
        return status, hdrs, payload

    def wait(self, rid: str, states=("complete",), timeout_s: float = 60.0) -> dict:
        """Poll GET /runs/<id> until its status is in ``states`` (bounded)."""
        deadline = time.monotonic() + timeout_s
        while True:
            status, _, s = self.call("GET", f"/runs/{rid}")
            assert status == 200, s
            if s["status"] in states:
                return s
            assert s["status"] not in ("failed", "interrupted"), s
            if time.monotonic() > deadline:
                raise TimeoutError(f"run {rid} still {s['status']}")
            time.sleep(0.1)

    def kill(self, sig=signal.SIGKILL) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=20)
        self.log.close()
