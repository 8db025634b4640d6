"""Atomic multi-file output: every file is written under a temporary sibling name and all are
renamed into place only when every one of them was written completely.

Nothing at the final paths changes when an error (or Ctrl-C) happens, and existing files are
never replaced unless ``overwrite`` is set (checked for all targets before anything is written).
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path

from turbgen.errors import ParameterError


class OutputSet:
    """Context manager handing out temporary paths for a set of final paths.

    >>> with OutputSet([a, b], overwrite=False) as out:
    ...     write(out.temp(a)); write(out.temp(b))
    """

    def __init__(self, paths, *, overwrite: bool):
        self.paths = [Path(p) for p in paths]
        if len(set(self.paths)) != len(self.paths):
            raise ParameterError(f"output paths {[str(p) for p in self.paths]} are not distinct")
        for p in self.paths:
            if not p.parent.is_dir():
                raise ParameterError(f"output directory {str(p.parent)!r} does not exist")
            if p.is_dir():
                raise ParameterError(f"output {str(p)!r} is a directory")
            if p.exists() and not overwrite:
                raise ParameterError(f"output {str(p)!r} exists; pass --overwrite to replace it")
        token = f"{os.getpid()}-{secrets.token_hex(4)}"
        self._temps = {p: p.with_name(f".{p.name}.tmp-{token}") for p in self.paths}

    def temp(self, path) -> Path:
        """Temporary path to write instead of the final ``path``."""
        return self._temps[Path(path)]

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            missing = [str(p) for p, t in self._temps.items() if not t.exists()]
            if missing:
                self._cleanup()
                raise RuntimeError(f"exporter did not write {missing}")
            for p, t in self._temps.items():
                os.replace(t, p)
        else:
            self._cleanup()
        return False

    def _cleanup(self):
        for t in self._temps.values():
            try:
                t.unlink()
            except FileNotFoundError:
                pass
