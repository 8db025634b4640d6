"""Discarding a store writer's directory: no zarr I/O of the writer left running, then the directory removed.
"""

from __future__ import annotations

import shutil
import threading
from pathlib import Path


def finish_before_raising(fn, *args):
    """``fn(*args)``, run to its end even when the calling thread is interrupted while it runs (zarr writes in its own
    event-loop thread, and a KeyboardInterrupt or SystemExit in the waiting thread would leave that I/O recreating files
    in a temporary directory being removed). In the main thread ``fn`` runs in a helper thread that an interruption
    waits for (a second one stops the wait)."""
    if threading.current_thread() is not threading.main_thread():
        return fn(*args)
    done, lock, state, out = threading.Event(), threading.Lock(), ["pending"], []

    def run():
        with lock:
            if state[0] == "cancelled":
                return
            state[0] = "running"
        try:
            out.append((True, fn(*args)))
        except BaseException as exc:
            out.append((False, exc))
        finally:
            done.set()

    try:
        threading.Thread(target=run, name="turbgen-zarr-call").start()
        done.wait()
    except BaseException:
        with lock:
            running, state[0] = state[0] == "running", "cancelled"
        if running:
            done.wait()
        raise
    ok, value = out[0]
    if not ok:
        raise value
    return value


def remove_path(path: Path) -> None:
    """Remove ``path``: a directory tree (not followed through a symlink), a file or a symlink; nothing if absent."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    elif path.exists() or path.is_symlink():
        path.unlink()
