"""Start-up clean-up of a server's root, and the size cap of its stencil cache.

Every writer of the service works under a temporary name with its process id (``.NAME.tmp-PID-XXXXXXXX``,
turbgen.store.temporaries): a killed server (kill -9, power loss) leaves them behind. Start-up removes those whose
process is gone, in ``ROOT/work`` (derived products), ``ROOT/runs`` (runs being deleted), ``ROOT/constraints``
(uploads), each run's directory, its ``exports`` and ``lidar`` (written there by earlier versions), and in
``ROOT/stencils`` when the runs execute in this process (with --scheduler the stencil builders are the scheduler's
workers, whose process ids are not this host's). Earlier versions also named validation and export temporaries
``.tmp-XXXXXXXX`` without a process id: only a server writes them and start-up is before it writes, so start-up
removes them all.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from turbgen.service.catalog import Catalog
from turbgen.service.run_ids import valid_id
from turbgen.store.temporaries import remove_dead_temporaries

STENCIL_GLOB = "mann-stencil-*.npy"  # the entries of turbgen.runs.stencil_cache (stencils and systems)
DEFAULT_STENCIL_CACHE_BYTES = 4 * 2**30


def remove_dead_work(catalog: Catalog, *, stencils: bool) -> list[Path]:
    """Remove the temporaries of dead processes under the catalog's root (see the module's docstring).

    Parameters
    ----------
    catalog : Catalog
        The server's catalog.
    stencils : bool
        Also in ``ROOT/stencils`` (the server's own cluster).

    Returns
    -------
    list of Path
        The removed paths.
    """
    removed = (remove_dead_temporaries(catalog.work) + remove_dead_temporaries(catalog.runs)
               + remove_dead_temporaries(catalog.uploads.dir))  # fmt: skip
    for run_dir in catalog.runs.iterdir():
        if not valid_id(run_dir.name) or not run_dir.is_dir():
            continue
        for d in (run_dir, run_dir / "exports", run_dir / "lidar"):
            removed += remove_dead_temporaries(d) + _remove_unowned(d)
    if stencils:
        removed += remove_dead_temporaries(catalog.root / "stencils")
    return removed


def _remove_unowned(directory: Path) -> list[Path]:
    """Remove ``.tmp-*`` entries of ``directory`` (earlier versions' temporaries without a process id)."""
    removed = []
    for p in directory.glob(".tmp-*") if directory.is_dir() else ():
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
        removed.append(p)
    return removed


def trim_stencil_cache(directory: Path, max_bytes: int | None) -> list[Path]:
    """Evict the least recently used stencils of ``directory`` until its entries take at most ``max_bytes``.

    Recency is an entry's modification time, which the cache renews on every hit (turbgen.runs.stencil_cache);
    the most recent entry is kept even when it alone is larger (the run using it needs it). A run that has an
    evicted entry memory-mapped keeps reading it (the file is gone only when unmapped).

    Parameters
    ----------
    directory : Path
        The stencil cache (``ROOT/stencils``); missing is empty.
    max_bytes : int or None
        The cap [bytes]; None: no cap.

    Returns
    -------
    list of Path
        The evicted entries, oldest first.
    """
    if max_bytes is None or not directory.is_dir():
        return []
    entries = []
    for p in directory.glob(STENCIL_GLOB):
        try:
            st = p.stat()
        except FileNotFoundError:
            continue
        entries.append((st.st_mtime_ns, p.name, st.st_size, p))
    entries.sort()
    total = sum(e[2] for e in entries)
    evicted = []
    for _, _, size, p in entries[:-1]:
        if total <= max_bytes:
            break
        try:
            os.unlink(p)
        except FileNotFoundError:
            pass
        total -= size
        evicted.append(p)
    return evicted
