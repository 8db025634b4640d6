"""Temporary names of unfinished outputs, the liveness of their writers, and atomic publication.

Every turbgen writer (field stores, exports, manifests) works under a hidden sibling name
``.NAME.tmp-PID-XXXXXXXX`` (PID = the writing process) and renames it to ``NAME`` only when
complete. A temporary whose PID is dead on this host (killed with SIGKILL, power loss) is garbage:
:func:`remove_dead_temporaries` deletes it (the next write of the same output, ``turbgen info``
and ``turbgen sweep`` call it and say so in one line). Signals are the application's business
(:mod:`turbgen.interruption`): here an exception leaving a writer removes its temporary, and a process killed
outright leaves garbage of a dead writer, never a complete-looking output.
"""

from __future__ import annotations

import errno
import os
import shutil
import sys
from pathlib import Path

from turbgen import oscalls
from turbgen.atomic import TEMP_MARK, temp_name, temp_prefix  # noqa: F401 (re-exported)


def pid_alive(pid: int) -> bool:
    """True if a process with this pid exists on this host (EPERM counts as alive, a zombie as dead).

    Parameters
    ----------
    pid : int
        Process id; values <= 0 are never alive.

    Returns
    -------
    bool
        Whether the process exists and is not a zombie.
    """
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
    """(final name, writer pid) of a temporary name ``.NAME.tmp-PID-...``, else None.

    Parameters
    ----------
    name : str
        A file or directory name (no directory part).

    Returns
    -------
    tuple of (str, int) or None
        (NAME, PID), or None when ``name`` is not a temporary name.
    """
    if not name.startswith(".") or TEMP_MARK not in name:
        return None
    final, _, rest = name[1:].rpartition(TEMP_MARK)
    pid_text = rest.split("-", 1)[0]
    if not final or not pid_text.isdigit():
        return None
    return final, int(pid_text)


def remove_dead_temporaries(directory, names=None) -> list[Path]:
    """Delete temporaries in ``directory`` (of the outputs ``names``, or all) whose writer is dead.

    Unreadable directories and entries that vanish meanwhile are skipped, as are entries that cannot
    be removed (read-only or foreign).

    Parameters
    ----------
    directory : str or os.PathLike
        Directory to clean.
    names : iterable of str, optional
        Final names whose temporaries may be removed; None (default) for all.

    Returns
    -------
    list of pathlib.Path
        The removed paths.
    """
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
        except FileNotFoundError:
            continue
        except OSError:
            continue  # read-only or foreign: leave it, the caller's own write reports the real problem
        removed.append(entry)
    return removed


def removed_line(removed) -> str:
    """One line naming the removed temporaries (empty when none).

    Parameters
    ----------
    removed : iterable of pathlib.Path
        Paths returned by :func:`remove_dead_temporaries`.

    Returns
    -------
    str
        The message, or "" when nothing was removed.
    """
    removed = list(removed)
    if not removed:
        return ""
    first = removed[0]
    more = f" and {len(removed) - 1} more" if len(removed) > 1 else ""
    return f"removed {first}{more} (temporary of an interrupted write whose process is gone)"


def report_removed(removed) -> None:
    """Print :func:`removed_line` on stderr when something was removed.

    Parameters
    ----------
    removed : iterable of pathlib.Path
        Paths returned by :func:`remove_dead_temporaries`.

    Returns
    -------
    None
    """
    line = removed_line(removed)
    if line:
        print(line, file=sys.stderr)


def publish(tmp: Path, path: Path, *, replace: bool) -> Path | None:
    """Move the finished temporary ``tmp`` to ``path`` atomically.

    ``replace`` False: fails with FileExistsError if ``path`` exists (never clobbers, also not a
    directory created meanwhile). ``replace`` True: ``path`` is swapped with ``tmp`` in one step
    (renameat2 RENAME_EXCHANGE), so readers always see either the old or the new complete output;
    the old one is left at the temporary name (a dead writer's garbage if we are killed now) and
    returned for the caller to delete. Where renameat2 is missing, the old output is first renamed
    to a temporary name of this process, then the new one renamed in (a short window without
    ``path``; a writer losing a race against another one gets FileExistsError).

    Parameters
    ----------
    tmp : str or os.PathLike
        The finished temporary (file or directory), a sibling of ``path``.
    path : str or os.PathLike
        The final path.
    replace : bool
        Allow replacing an existing ``path``.

    Returns
    -------
    pathlib.Path or None
        Where the old output now lies (for the caller to delete), or None when nothing was replaced.

    Raises
    ------
    FileExistsError
        When ``path`` exists and ``replace`` is False, or another writer replaced it meanwhile.
    OSError
        For other rename failures.
    """
    tmp, path = Path(tmp), Path(path)
    exists = path.exists() or path.is_symlink()
    if not replace or not exists:
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
    """Write the file ``path`` through ``write(tmp)`` under a temporary name, then rename it into place (replacing an
    older one): a failed write (a full disk) leaves neither a partial file nor the temporary.

    Parameters
    ----------
    path : str or os.PathLike
        The final file.
    write : callable
        ``write(tmp)`` writes the whole file at the path ``tmp`` (whose name has no meaningful suffix: give the
        format explicitly, e.g. ``fig.savefig(tmp, format="png")``).
    what : str
        What the file is, for the error (e.g. "the plot").

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ParameterError
        One line naming ``path`` when the file system refuses the write (ENOSPC, EACCES, ...).
    """
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
