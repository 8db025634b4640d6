"""A lock file that keeps two sweeps from writing the same output directory.

``DIR/.turbgen-sweep.lock`` is created with O_CREAT | O_EXCL and holds the owner's host, pid and
start time (JSON). A lock left by a process that no longer exists on this host is stale and is
taken over; a lock of a live process, or of another host (which cannot be checked), is refused.
"""

from __future__ import annotations

import json
import os
import socket
from datetime import datetime, timezone
from pathlib import Path

from turbgen.errors import TurbgenError
from turbgen.store.temporaries import pid_alive  # the one liveness test, shared with the store writers

LOCK_NAME = ".turbgen-sweep.lock"


class SweepLockedError(TurbgenError):
    """Another sweep (alive, or on another host) holds the directory's lock."""


class SweepLock:
    """Context manager holding DIR's sweep lock; released on exit (only if still ours).

    Parameters
    ----------
    directory : str or Path
        The sweep's output directory; the lock is ``directory/.turbgen-sweep.lock``. Entering the
        context calls :meth:`acquire` (SweepLockedError if another sweep holds it).
    """

    def __init__(self, directory: str | Path):
        self.path = Path(directory) / LOCK_NAME
        self.owner = {
            "host": socket.gethostname(),
            "pid": os.getpid(),
            "started_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        }

    def _read(self) -> dict | None:
        try:
            data = json.loads(self.path.read_text())
            return data if isinstance(data, dict) else {}
        except FileNotFoundError:
            return None
        except (OSError, ValueError):
            return {}  # unreadable or half-written: treated as held by an unknown owner

    def _stale(self, holder: dict) -> bool:
        pid = holder.get("pid")
        return holder.get("host") == self.owner["host"] and isinstance(pid, int) and not pid_alive(pid)

    def acquire(self) -> "SweepLock":
        """Create the lock file with this process as owner, taking over a stale lock of a dead local process.

        Returns
        -------
        SweepLock
            ``self``.

        Raises
        ------
        SweepLockedError
            If a live process, one on another host, or an unreadable lock holds the directory, or the lock
            file keeps changing (three attempts).
        """
        for _ in range(3):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                holder = self._read()
                if holder is None:
                    continue  # released between our open and read: retry
                if self._stale(holder):
                    self.path.unlink(missing_ok=True)
                    continue
                pid, host, since = (holder.get(k, "?") for k in ("pid", "host", "started_utc"))
                who = f"pid {pid} on {host} since {since}"
                raise SweepLockedError(
                    f"{self.path.parent} is locked by another sweep ({who}); "
                    f"delete {self.path} only if that sweep is no longer running"
                ) from None
            with os.fdopen(fd, "w") as fh:
                json.dump(self.owner, fh)
            return self
        raise SweepLockedError(f"could not take the lock {self.path} (it keeps changing)")

    def release(self) -> None:
        """Remove the lock file if it still names this owner (a lock taken over by another sweep is left).

        Returns
        -------
        None
        """
        if self._read() == self.owner:
            self.path.unlink(missing_ok=True)

    def __enter__(self) -> "SweepLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
