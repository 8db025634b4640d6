"""Checks of an output path before anything is written: one line naming the path, never a traceback."""

from __future__ import annotations

import os
from pathlib import Path

from turbgen.errors import ParameterError

# Longest file name [bytes] of an output: NAME_MAX (255 on Linux/macOS file systems) minus room for the
# hidden temporary and backup names the writers derive from it (".NAME.tmp-PID-XXXXXXXX", ".NAME.old-...").
MAX_NAME_BYTES = 200


def check_output_path(path, what: str = "--out", *, create_parents: bool = False) -> Path:
    """``path`` (``~`` expanded) if a file or directory can be created there, else ParameterError naming it; refused: an
    empty path, a name over MAX_NAME_BYTES, an ancestor that is a file or a zarr store, and (unless ``create_parents``)
    a missing parent; ``what`` names the option in messages."""
    if path is None:
        raise ParameterError(f"{what} = None; give a file or directory name")
    text = os.fspath(path)
    if not str(text).strip():
        raise ParameterError(f"{what} = {text!r} is empty; give a file or directory name")
    p = Path(text).expanduser()
    name = p.name or p.absolute().name
    if len(os.fsencode(name)) > MAX_NAME_BYTES:
        raise ParameterError(f"{what}: the name {name[:40]!r}... is {len(os.fsencode(name))} bytes long; the maximum "
                             f"is {MAX_NAME_BYTES}")
    parent = Path(os.path.abspath(p)).parent  # '..' folded: a.zarr/../b.zarr is not inside a.zarr
    for ancestor in (parent, *parent.parents):
        if ancestor.exists():
            if not ancestor.is_dir():
                raise ParameterError(f"{what} = {text!r}: {str(ancestor)!r} is a file, not a directory")
            break
    store = enclosing_store(parent)
    if store is not None:
        raise ParameterError(f"{what} = {text!r} is inside the store {str(store)!r}; write it beside the store")
    if not parent.exists() and not create_parents:
        raise ParameterError(f"{what} = {text!r}: output directory {str(parent)!r} does not exist")
    return p


def enclosing_store(directory: Path) -> Path | None:
    """The nearest of absolute ``directory`` (need not exist) and its ancestors holding a zarr.json, or None."""
    for d in (directory, *directory.parents):
        if (d / "zarr.json").is_file():
            return d
    return None


def check_output_dir(path, what: str) -> Path:
    """:func:`check_output_path` for a directory of outputs; also ParameterError for a zarr node at ``path``."""
    p = check_output_path(path, what, create_parents=True)
    if (p / "zarr.json").is_file():
        raise ParameterError(f"{what} = {str(path)!r} is a field store, not a sweep directory; give another directory")
    return p
