"""Start-up clean-up of a server's root, and the size cap of its stencil cache.

Start-up removes the temporaries (turbgen.store.temporaries) whose process is gone; in ``ROOT/stencils`` only when the
runs execute in this process (with --scheduler the builders' process ids are not this host's)."""

from __future__ import annotations

from pathlib import Path

from turbgen.service.catalog import Catalog
from turbgen.store.discard import remove_path
from turbgen.service.run_ids import valid_id
from turbgen.store.temporaries import remove_dead_temporaries

STENCIL_GLOB = "mann-stencil-*.npy"  # the entries of turbgen.runs.stencil_cache (stencils and systems)
DEFAULT_STENCIL_CACHE_BYTES = 4 * 2**30


def remove_dead_work(catalog: Catalog, *, stencils: bool) -> list[Path]:
    """Remove the temporaries of dead processes under the catalog's root, also in ``ROOT/stencils`` if ``stencils``;
    the removed paths."""
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
    """Remove the ``.tmp-*`` entries (temporaries without a process id) of ``directory``."""
    removed = list(directory.glob(".tmp-*")) if directory.is_dir() else []
    for p in removed:
        remove_path(p)
    return removed


def trim_stencil_cache(directory: Path, max_bytes: int | None) -> list[Path]:
    """Evict the least recently used stencils (modification time) of ``directory`` until they take at most
    ``max_bytes`` (None: no cap), keeping the most recent; the evicted entries, oldest first."""
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
        p.unlink(missing_ok=True)
        total -= size
        evicted.append(p)
    return evicted
