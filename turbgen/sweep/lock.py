"""A lock keeping two sweeps from writing one output directory (``filelock``): ``DIR/.turbgen-sweep.lock``.

An OS file lock (a killed sweep holds nothing) naming its owner (host, pid, start) for the refusal; removed on
release while still held, safe because a SweepLock never waits."""

from __future__ import annotations

import json
import os
import socket
from pathlib import Path

from filelock import FileLock, Timeout

from turbgen.errors import TurbgenError
from turbgen.sweep.manifest import utc_now

LOCK_NAME = ".turbgen-sweep.lock"


class SweepLockedError(TurbgenError):
    """Another sweep holds the directory's lock."""


class SweepLock:
    """Context manager holding ``directory/.turbgen-sweep.lock``; entering calls :meth:`acquire`, exit releases."""

    def __init__(self, directory: str | Path):
        self.path = Path(directory) / LOCK_NAME
        self.owner = {"host": socket.gethostname(), "pid": os.getpid(), "started_utc": utc_now()}
        self._lock = FileLock(self.path, blocking=False, on_acquired=self._write_owner)

    def _write_owner(self, fd: int) -> None:
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(self.owner).encode(), 0)

    def _holder(self) -> dict:
        try:
            data = json.loads(self.path.read_text())
        except (OSError, ValueError):  # released meanwhile, or being written
            return {}
        return data if isinstance(data, dict) else {}

    def acquire(self) -> "SweepLock":
        """Take the lock without waiting; return ``self``. SweepLockedError if another sweep holds it."""
        try:
            self._lock.acquire()
        except Timeout:
            pid, host, since = (self._holder().get(k, "?") for k in ("pid", "host", "started_utc"))
            raise SweepLockedError(f"{self.path.parent} is locked by another sweep (pid {pid} on {host} since "
                                   f"{since}); wait for it to finish or use another `out`") from None
        return self

    def release(self) -> None:
        """Release the lock, removing its file first (module docstring)."""
        if self._lock.is_locked:
            try:
                self.path.unlink(missing_ok=True)
            finally:
                self._lock.release()

    def __enter__(self) -> "SweepLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
