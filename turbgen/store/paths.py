"""Checks of an output path before anything is written: one line naming the path, never a traceback."""

from __future__ import annotations

import os
from pathlib import Path

from turbgen.errors import ParameterError

# Longest file name [bytes] of an output: NAME_MAX (255 on Linux/macOS file systems) minus room for the
# hidden temporary and backup names the writers derive from it (".NAME.tmp-PID-XXXXXXXX", ".NAME.old-...").
MAX_NAME_BYTES = 200


def check_output_path(path, what: str = "--out", *, create_parents: bool = False) -> Path:
    """``path`` as a Path if a file or directory can be created there, else ParameterError naming it.

    Refused: an empty path, a name longer than MAX_NAME_BYTES, an ancestor that is a file, and (unless
    ``create_parents``: the caller makes missing directories) a parent that does not exist.
    (Existence of ``path`` itself and --overwrite are the writers' business.)

    Parameters
    ----------
    path : str or os.PathLike
        The output path (``~`` is expanded).
    what : str, optional
        Name of the option in messages; default "--out".
    create_parents : bool, optional
        Accept a missing parent directory (the caller creates it).

    Returns
    -------
    pathlib.Path
        ``path`` with ``~`` expanded (not made absolute).

    Raises
    ------
    ParameterError
        For any refused path (one line naming it).
    """
    text = os.fspath(path) if path is not None else ""
    if not str(text).strip():
        raise ParameterError(f"{what} = {text!r} is empty; give a file or directory name")
    p = Path(text).expanduser()
    name = p.name or p.absolute().name
    if len(os.fsencode(name)) > MAX_NAME_BYTES:
        raise ParameterError(
            f"{what}: the name {name[:40]!r}... is {len(os.fsencode(name))} bytes long; the maximum is {MAX_NAME_BYTES}"
        )
    parent = p.absolute().parent
    for ancestor in (parent, *parent.parents):
        if ancestor.exists():
            if not ancestor.is_dir():
                raise ParameterError(f"{what} = {text!r}: {str(ancestor)!r} is a file, not a directory")
            break
    if not parent.exists() and not create_parents:
        raise ParameterError(f"{what} = {text!r}: output directory {str(parent)!r} does not exist")
    return p
