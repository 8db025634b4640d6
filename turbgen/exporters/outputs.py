"""Atomic multi-file output: each file is written under a temporary sibling, all renamed into place once complete.

Nothing at the final paths changes on an error (Ctrl-C, SIGTERM, a full disk); temporaries of exports killed
earlier are removed by the next export."""

from __future__ import annotations

import errno
import os
import secrets
from pathlib import Path

from turbgen import oscalls
from turbgen.errors import ParameterError
from turbgen.store.paths import check_output_path
from turbgen.resources import available_disk_bytes
from turbgen.cancellation import raise_if_stop_requested
from turbgen.store.temporaries import TEMP_MARK, remove_dead_temporaries, report_removed


class OutputSet:
    """Context manager handing out temporary paths for a set of final paths, renamed into place on normal exit, all
    removed on an exception (RuntimeError if one was not written). ParameterError for a bad, existing (without
    ``overwrite``) or unwritable output."""

    def __init__(self, paths, *, overwrite: bool):
        self.paths = [Path(p) for p in paths]
        if len(set(self.paths)) != len(self.paths):
            raise ParameterError(f"output paths {[str(p) for p in self.paths]} are not distinct")
        for p in self.paths:
            check_output_path(p)
            if not p.parent.is_dir():
                raise ParameterError(f"output directory {str(p.parent)!r} does not exist")
            if p.is_dir():
                raise ParameterError(f"output {str(p)!r} is a directory")
            if p.exists() and not overwrite:
                raise ParameterError(f"output {str(p)!r} exists; pass `overwrite` to replace it")
            if not os.access(p.parent, os.W_OK):
                raise ParameterError(f"output directory {str(p.parent)!r} is not writable")
        for parent in {p.parent for p in self.paths}:
            report_removed(remove_dead_temporaries(parent, [p.name for p in self.paths if p.parent == parent]))
        token = f"{os.getpid()}-{secrets.token_hex(4)}"
        self._temps = {p: p.with_name(f".{p.name}{TEMP_MARK}{token}") for p in self.paths}

    def temp(self, path) -> Path:
        """The hidden temporary sibling ``.NAME.tmp-PID-XXXXXXXX`` to write instead of the final ``path``."""
        return self._temps[Path(path)]

    def reserve(self, path, nbytes: int) -> None:
        """Reserve ``nbytes`` of disk for the existing temporary of ``path`` without changing its size (OSError
        ENOSPC if missing): HDF5 aborts the process when it cannot flush on close. Without fallocate(2) the free
        space is checked instead."""
        fd = os.open(self.temp(path), os.O_WRONLY)
        try:
            if not oscalls.reserve(fd, int(nbytes), keep_size=True, name=str(self.temp(path))):
                free = available_disk_bytes(self.temp(path))
                if free is not None and nbytes > free:
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.temp(path)))
        finally:
            os.close(fd)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            try:
                raise_if_stop_requested()  # an interruption whose exception was swallowed on the way publishes nothing
            except BaseException:
                self._cleanup()
                raise
            missing = [str(p) for p, t in self._temps.items() if not t.exists()]
            if missing:
                self._cleanup()
                raise RuntimeError(f"exporter did not write {missing}")
            try:
                for p, t in self._temps.items():
                    os.truncate(t, t.stat().st_size)  # release reserved blocks past the end
                    os.replace(t, p)
            except OSError as err:
                exc = err
            else:
                return False
        self._cleanup()
        if isinstance(exc, OSError):
            reason = write_failure(exc)
            where = ", ".join(str(p) for p in self.paths)
            raise ParameterError(f"writing {where} failed: {reason}; nothing was written") from None
        return False

    def _cleanup(self):
        for t in self._temps.values():
            try:
                t.unlink(missing_ok=True)
            except OSError:
                pass  # e.g. a read-only directory where the temporary was never created


def write_failure(exc: OSError) -> str:
    """The reason of a failed write in a few words: its errno's message, else the first line of the library's
    (numpy's short write without errno: the disk is probably full)."""
    if exc.errno:
        return f"{os.strerror(exc.errno)} (errno {exc.errno})"
    text = (str(exc).splitlines() or [type(exc).__name__])[0]
    if "requested and" in text and "written" in text:  # numpy: "N requested and M written", the disk took no more
        return f"a short write ({text}): the disk is probably full"
    return text
