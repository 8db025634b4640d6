"""Discarding a store writer's directory: zarr's pending I/O drained first, then the directory removed.
"""

from __future__ import annotations

import shutil
from pathlib import Path


def drain_zarr_io(timeout_s: float = 10.0) -> None:
    """Wait for zarr's I/O tasks still running in its event-loop thread (a Ctrl-C interrupts the
    waiting, not the writing): otherwise they recreate files in a directory being removed, and
    print tracebacks at interpreter shutdown."""
    import asyncio

    from zarr.core import sync as zsync

    loop = zsync.loop[0]
    if loop is None or loop.is_closed() or not loop.is_running():
        return

    async def wait_others():
        me = asyncio.current_task()
        others = [t for t in asyncio.all_tasks() if t is not me]
        if others:
            await asyncio.wait(others, timeout=timeout_s)

    try:
        asyncio.run_coroutine_threadsafe(wait_others(), loop).result(timeout_s + 1)
    except Exception:  # noqa: BLE001 - best effort: the directory is removed anyway
        pass


def remove_path(path: Path) -> None:
    """Remove ``path``: a directory tree (not followed through a symlink), a file or a symlink; nothing if absent."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    elif path.exists() or path.is_symlink():
        path.unlink()
