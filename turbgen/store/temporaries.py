"""Temporaries of unfinished outputs (turbgen.atomic), the liveness of their writers, and atomic publication."""

from __future__ import annotations

import errno
import os
import shutil
import sys
from pathlib import Path

from turbgen import oscalls
from turbgen.atomic import TEMP_MARK, temp_name, temp_prefix  # noqa: F401 (re-exported)


def pid_alive(pid: int) -> bool:
    """True if a process with this pid (> 0) exists on this host (EPERM counts as alive, a zombie as dead)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return not oscalls.is_zombie(pid)


def parse_temp(name: str) -> tuple[str, int] | None:
    """(NAME, PID) of a temporary file or directory name ``.NAME.tmp-PID-...`` (no directory part), else None."""
    if not name.startswith(".") or TEMP_MARK not in name:
        return None
    final, _, rest = name[1:].rpartition(TEMP_MARK)
    pid_text = rest.split("-", 1)[0]
    if not final or not pid_text.isdigit():
        return None
    return final, int(pid_text)


def remove_dead_temporaries(directory, names=None) -> list[Path]:
    """Delete the temporaries in ``directory`` (of ``names``, or all) whose writer is dead; the removed paths."""
    directory = Path(directory)
    wanted = None if names is None else set(names)
    removed = []
    try:
        entries = list(directory.iterdir())
    except OSError:
        return removed
    for entry in entries:
        parsed = parse_temp(entry.name)
        if parsed is None or (wanted is not None and parsed[0] not in wanted) or pid_alive(parsed[1]):
            continue
        try:
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry)
            else:
                entry.unlink()
        except OSError:  # vanished, read-only or foreign: the caller's own write reports a real problem
            continue
        removed.append(entry)
    return removed


def removed_line(removed) -> str:
    """One line naming the temporaries :func:`remove_dead_temporaries` removed ("" when none)."""
    removed = list(removed)
    if not removed:
        return ""
    more = f" and {len(removed) - 1} more" if len(removed) > 1 else ""
    return f"removed {removed[0]}{more} (temporary of an interrupted write whose process is gone)"


def report_removed(removed) -> None:
    """Print :func:`removed_line` on stderr when something was removed."""
    line = removed_line(removed)
    if line:
        print(line, file=sys.stderr)


def publish(tmp: Path, path: Path, *, replace: bool) -> Path | None:
    """Move the finished temporary sibling ``tmp`` to ``path`` atomically; returns where the old output lies, or None;
    ``replace`` False: FileExistsError if ``path`` exists. True: swapped in one step (renameat2 RENAME_EXCHANGE), the
    old output left at the temporary name for the caller to delete; without renameat2, two renames (a short window
    without ``path``)."""
    tmp, path = Path(tmp), Path(path)
    if not replace or not (path.exists() or path.is_symlink()):
        if oscalls.rename_noreplace(tmp, path):
            return None
        if path.exists() or path.is_symlink():
            raise FileExistsError(errno.EEXIST, "exists", str(path))
        os.rename(tmp, path)
        return None
    if oscalls.rename_exchange(tmp, path):
        return tmp
    old = temp_name(path)
    os.rename(path, old)
    try:
        os.rename(tmp, path)
    except BaseException:
        try:
            os.rename(old, path)
        except OSError:  # another writer published meanwhile: ours lost the race, the old store is stale
            shutil.rmtree(old, ignore_errors=True)
            raise FileExistsError(errno.EEXIST, "another writer replaced it meanwhile", str(path)) from None
        raise
    return old


def write_atomically(path: Path, write, what: str) -> Path:
    """Write the file ``path`` by ``write(tmp)`` under a temporary name (its suffix means nothing: give the format),
    then rename it into place; returns ``path``. ParameterError naming ``what`` and ``path`` on a refused write."""
    from turbgen.errors import ParameterError

    path = Path(path)
    tmp = temp_name(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        raise ParameterError(f"{what} {path}: cannot write it ({exc.strerror or exc})") from None
    finally:
        tmp.unlink(missing_ok=True)
    return path
