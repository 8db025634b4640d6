"""The operating-system calls that only some systems have (Linux), each with its portable fallback, in one place.

renameat2(2), fallocate(2) (a full disk met when the space is asked for, not mid-write), /proc and
/sys/fs/cgroup, statvfs(2) and O_DIRECT; where missing, each function says so (False, None, 0) or gives the
portable answer. ``TURBGEN_PORTABLE=1`` (read at every call) forces the fallbacks (tested on Linux too)."""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import os
import shutil
import sys
from pathlib import Path

PORTABLE_ENV = "TURBGEN_PORTABLE"

PROC_STATUS = Path("/proc/self/status")
PROC_MEMINFO = Path("/proc/meminfo")
CGROUP_ROOT = Path("/sys/fs/cgroup")

_RENAME_NOREPLACE, _RENAME_EXCHANGE, _AT_FDCWD = 1, 2, -100
_FALLOC_FL_KEEP_SIZE = 1
_UNSUPPORTED = (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.ENOTSUP)


def portable() -> bool:
    """True when ``TURBGEN_PORTABLE`` is set to anything but "" or "0": every function here takes its fallback."""
    return os.environ.get(PORTABLE_ENV, "") not in ("", "0")


def _libc_function(name: str):
    """The C library's function ``name`` (errno kept), or None where it is missing or the fallbacks are forced."""
    if portable() or not sys.platform.startswith("linux"):
        return None
    libc_name = ctypes.util.find_library("c")
    return getattr(ctypes.CDLL(libc_name, use_errno=True), name, None) if libc_name else None


def _renameat2(src: Path, dst: Path, flags: int) -> bool:
    """renameat2(2) with ``flags``; False when the C library or the file system lacks it."""
    fn = _libc_function("renameat2")
    if fn is None:
        return False
    fn.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint)
    if fn(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), flags) == 0:
        return True
    err = ctypes.get_errno()
    if err in _UNSUPPORTED:
        return False
    raise OSError(err, os.strerror(err), str(dst))


def rename_noreplace(src: Path, dst: Path) -> bool:
    """Rename ``src`` to ``dst`` in one step unless ``dst`` exists (FileExistsError); False without renameat2."""
    return _renameat2(src, dst, _RENAME_NOREPLACE)


def rename_exchange(src: Path, dst: Path) -> bool:
    """Swap the existing ``src`` and ``dst`` in one step; False, nothing done, without renameat2 RENAME_EXCHANGE."""
    return _renameat2(src, dst, _RENAME_EXCHANGE)


def reserve(fd: int, nbytes: int, *, keep_size: bool, name: str = "") -> bool:
    """Allocate ``nbytes`` of disk from offset 0 of the open file ``fd``, so later writes cannot meet a full disk
    (``keep_size``: fallocate(2) FALLOC_FL_KEEP_SIZE, else posix_fallocate(3)). False where the space cannot be
    reserved; OSError (ENOSPC, EDQUOT, naming ``name``) when the space is not there."""
    if nbytes <= 0:
        return True
    if keep_size:
        fn = _libc_function("fallocate")
        if fn is None:
            return False
        fn.argtypes = (ctypes.c_int, ctypes.c_int, ctypes.c_longlong, ctypes.c_longlong)
        err = 0 if fn(fd, _FALLOC_FL_KEEP_SIZE, 0, int(nbytes)) == 0 else ctypes.get_errno()
    else:
        if portable() or not hasattr(os, "posix_fallocate"):
            return False
        try:
            os.posix_fallocate(fd, 0, int(nbytes))
            err = 0
        except OSError as exc:
            err = exc.errno or 0
    if err in _UNSUPPORTED:
        return False
    if err:
        raise OSError(err, os.strerror(err), name or None)
    return True


def _proc_bytes(path: Path, key: str) -> int | None:
    """The value [kB] after ``key:`` in a /proc file in bytes, or None where it is missing, unreadable or forced off."""
    if portable():
        return None
    try:
        for line in path.read_text().splitlines():
            if line.startswith(key + ":"):
                value = line.split()[1]
                return int(value) * 1024 if value.isdigit() else None
    except (OSError, IndexError):
        return None
    return None


def resident_bytes(status: Path = PROC_STATUS) -> int | None:
    """This process's resident memory now [bytes] (VmRSS), or None where /proc does not tell (not Linux)."""
    return _proc_bytes(status, "VmRSS")


def meminfo_available_bytes(meminfo: Path = PROC_MEMINFO) -> int | None:
    """MemAvailable of /proc/meminfo [bytes], or None where it is missing."""
    return _proc_bytes(meminfo, "MemAvailable")


def _read_int(path: Path) -> int | None:
    try:
        return int(path.read_text().strip())
    except (OSError, ValueError):  # missing file, or "max" (no limit)
        return None


def cgroup_headroom_bytes(root: Path = CGROUP_ROOT) -> int | None:
    """Limit minus usage of this process's memory cgroup (v2, then v1) [bytes], or None if unlimited or unknown."""
    if portable():
        return None
    for limit_file, usage_file in (("memory.max", "memory.current"),
                                   ("memory/memory.limit_in_bytes", "memory/memory.usage_in_bytes")):
        limit, usage = _read_int(root / limit_file), _read_int(root / usage_file)
        if limit is not None and usage is not None and limit < 2**60:  # v1 reports "no limit" as ~2^63
            return max(limit - usage, 0)
    return None


def is_zombie(pid: int) -> bool:
    """A killed process not yet reaped (state Z in /proc/PID/stat); False where /proc does not tell."""
    if portable():
        return False
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[-1].split()[0] == "Z"


def disk_free_bytes(path: Path) -> int | None:
    """Bytes an unprivileged writer can still put on ``path``'s file system (statvfs f_bavail); None if unknown."""
    try:
        if hasattr(os, "statvfs") and not portable():
            st = os.statvfs(path)
            return st.f_bavail * st.f_frsize
        return shutil.disk_usage(path).free
    except OSError:
        return None


def direct_io_flag() -> int:
    """``os.O_DIRECT`` (I/O bypassing the page cache), or 0 where missing or forced off (buffered I/O)."""
    return 0 if portable() else getattr(os, "O_DIRECT", 0)
