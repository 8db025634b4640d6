"""Temporary names of unfinished outputs and the one writer of small whole files (JSON, text, uploads).

Every turbgen writer works under a hidden sibling ``.NAME.tmp-PID-XXXXXXXX`` (PID = the writing process) and
renames it to ``NAME`` only when complete; :mod:`turbgen.store.temporaries` removes the temporaries of dead writers."""

from __future__ import annotations

import os
import secrets
from pathlib import Path

TEMP_MARK = ".tmp-"


def temp_prefix(path: Path, mark: str = TEMP_MARK) -> str:
    """``.NAME.tmp-``: the name prefix of the temporary siblings used while writing ``path`` (named NAME)."""
    return f".{Path(path).name}{mark}"


def temp_name(path: Path, mark: str = TEMP_MARK) -> Path:
    """A fresh temporary sibling ``.NAME.tmp-PID-XXXXXXXX`` of ``path`` owned by this process (8 random hex digits;
    ``mark`` in place of ``.tmp-``)."""
    path = Path(path)
    return path.parent / f"{temp_prefix(path, mark)}{os.getpid()}-{secrets.token_hex(4)}"


def write_file(path: Path, data: str | bytes) -> None:
    """Write ``data`` (a str as UTF-8) to ``path`` whole or not at all: a temporary sibling, fsync, then a rename
    over ``path``; mode 0o666 less the umask. OSError when it cannot be written (``path`` untouched)."""
    tmp = temp_name(path)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data.encode() if isinstance(data, str) else data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
