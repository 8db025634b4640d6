"""A lock that keeps two sweeps from writing the same output directory (the ``filelock`` package).

``DIR/.turbgen-sweep.lock`` is an OS file lock (flock; filelock's soft lock where there is none), so a sweep
that dies, even by SIGKILL, holds nothing any more. While held, the file names its owner's host, pid and
start time (JSON) for the refusal message. On release it is removed while still held, so nothing is left
behind; filelock itself never unlinks a Unix lock file because a *blocking* waiter could then lock the
removed inode, but a SweepLock never waits (a second sweep is refused at once).
"""

from __future__ import annotations

import json
import os
import socket
from datetime import datetime, timezone
from pathlib import Path

from filelock import FileLock, Timeout

from turbgen.errors import TurbgenError

LOCK_NAME = ".turbgen-sweep.lock"


class SweepLockedError(TurbgenError):
    """Another sweep holds the directory's lock."""


class SweepLock:
    """Context manager holding ``directory/.turbgen-sweep.lock``; entering calls :meth:`acquire`, exit releases."""

    def __init__(self, directory: str | Path):
        self.path = Path(directory) / LOCK_NAME
        self.owner = {
            "host": socket.gethostname(),
            "pid": os.getpid(),
            "started_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        }
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
        """Take the lock without waiting; return ``self``.

        Raises SweepLockedError if another sweep (another process, or another SweepLock of this process) holds it.
        """
        try:
            self._lock.acquire()
        except Timeout:
            pid, host, since = (self._holder().get(k, "?") for k in ("pid", "host", "started_utc"))
            raise SweepLockedError(
                f"{self.path.parent} is locked by another sweep (pid {pid} on {host} since {since}); "
                "wait for it to finish or use another `out`"
            ) from None
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
