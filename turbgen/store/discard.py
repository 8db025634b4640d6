"""Discarding a store writer's directory: no zarr I/O of the writer left running, then the directory removed.
"""

from __future__ import annotations

import concurrent.futures
import shutil
import threading
from pathlib import Path


def finish_before_raising(fn, *args):
    """``fn(*args)``, run to its end even when the calling thread is interrupted while it runs.

    zarr performs a write in its own event-loop thread while the caller waits; an exception raised in the waiting
    thread (Ctrl-C's KeyboardInterrupt, an application's signal turned into SystemExit) would leave that I/O running,
    to recreate files in a temporary directory being removed. In the main thread (the only one Python raises such
    exceptions in) ``fn`` therefore runs in a helper thread, and an interrupted wait waits for ``fn`` to end before
    the exception goes on (a second interruption stops that wait). Other threads call ``fn`` directly.

    Parameters
    ----------
    fn : callable
        The zarr call (a write, a metadata update).
    *args
        Its arguments.

    Returns
    -------
    object
        What ``fn`` returns.
    """
    if threading.current_thread() is not threading.main_thread():
        return fn(*args)
    pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="turbgen-zarr-call")
    future = pool.submit(fn, *args)
    try:
        return future.result()
    except BaseException:
        concurrent.futures.wait([future])  # fn's own exception: done already; an interruption: fn finishes first
        raise
    finally:
        pool.shutdown(wait=False)


def remove_path(path: Path) -> None:
    """Remove ``path``: a directory tree (not followed through a symlink), a file or a symlink; nothing if absent."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    elif path.exists() or path.is_symlink():
        path.unlink()
