"""Available memory and disk space, and the checks (ParameterError) before anything large is allocated or written."""

from __future__ import annotations

import os
from pathlib import Path

from turbgen import oscalls
from turbgen.errors import ParameterError


def default_threads(threads: int | None) -> int:
    """Threads of one run: ``threads`` if given, else os.cpu_count() (at least 1); never changes a field."""
    return max(1, int(threads or os.cpu_count() or 1))


def format_bytes(n: float) -> str:
    """``n`` bytes as a short human-readable string with binary units (e.g. '1.5 GiB')."""
    units = ("B", "KiB", "MiB", "GiB", "TiB")
    i = 0
    while abs(n) >= 1024 and i < len(units) - 1:
        n /= 1024
        i += 1
    return f"{n:.0f} B" if i == 0 else f"{n:.1f} {units[i]}"


def available_memory_bytes(meminfo: Path = oscalls.PROC_MEMINFO, cgroup_root: Path = oscalls.CGROUP_ROOT) -> int | None:
    """Memory [bytes] this process can still allocate (None: unknown): Linux MemAvailable capped by the cgroup
    limit minus usage; elsewhere free physical pages from ``os.sysconf`` (an underestimate: excludes caches)."""
    system = oscalls.meminfo_available_bytes(meminfo)
    if system is None:
        try:
            system = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (AttributeError, ValueError, OSError):
            pass
    headroom = oscalls.cgroup_headroom_bytes(cgroup_root)
    known = [v for v in (system, headroom) if v is not None]
    return min(known) if known else None


def require_memory(nbytes: int, what: str, hint: str) -> int | None:
    """Raise ParameterError naming ``what`` and ``hint`` (e.g. "lower `nt`") unless ``nbytes`` fit in the available
    memory; return the available bytes (None, passing, when unknown)."""
    available = available_memory_bytes()
    if available is not None and nbytes > available:
        raise ParameterError(f"{what} needs about {format_bytes(nbytes)} of memory but only {format_bytes(available)} "
                             f"is available; {hint}")
    return available


def available_disk_bytes(path) -> int | None:
    """Bytes an unprivileged writer can still put on the filesystem holding ``path`` (or its
    nearest existing parent), or None if it cannot be determined."""
    p = Path(path).expanduser().absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return oscalls.disk_free_bytes(p)


def require_disk(path, nbytes: int, what: str, hint: str) -> int | None:
    """Raise ParameterError as :func:`require_memory` unless ``nbytes`` fit on the filesystem of ``path`` (the
    output or its directory); return the free bytes (None, passing, when unknown)."""
    free = available_disk_bytes(path)
    if free is not None and nbytes > free:
        where = Path(path).expanduser().absolute()
        raise ParameterError(f"{what} needs about {format_bytes(nbytes)} of disk space but only {format_bytes(free)} "
                             f"is free at {where.parent if not where.is_dir() else where}; {hint}")
    return free


_SIZE_UNITS = {"": 1, "b": 1, "k": 1000, "kb": 1000, "kib": 2**10, "m": 10**6, "mb": 10**6, "mib": 2**20,
               "g": 10**9, "gb": 10**9, "gib": 2**30, "t": 10**12, "tb": 10**12, "tib": 2**40}  # fmt: skip


def parse_size(text: str, name: str = "size") -> int:
    """Bytes from a size such as '256MiB', '4GiB', '1.5GB' or '1000000' (binary and decimal units); ParameterError
    naming ``name`` and the accepted forms when ``text`` is not a positive size."""
    import re

    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([a-zA-Z]*)\s*", str(text))
    unit = m.group(2).lower() if m else ""
    if not m or unit not in _SIZE_UNITS or float(m.group(1)) <= 0:
        raise ParameterError(f"{name} {text!r} is not a size; give a positive number with a unit such as 256MiB or 4GiB")
    return int(float(m.group(1)) * _SIZE_UNITS[unit])
