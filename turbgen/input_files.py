"""The one place where a file a user names is opened for reading (``--config``, ``--constrain``, tables,
histories, lidar files, line-of-sight records, ``serve --token-file``, the service's uploads).

Rule: a regular file (or a link to one) of at most a size cap per kind. A FIFO, a device, a socket or a
directory is refused before anything is read (opened non-blocking, checked on the descriptor), and so
is a larger file (at most cap + 1 bytes are read, so neither /dev/zero nor a growing file can exhaust
memory): one ParameterError line naming the path and the rule."""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass
from pathlib import Path

from turbgen.errors import ParameterError


@dataclass(frozen=True)
class InputKind:
    """A kind of input file: ``name`` for messages (e.g. "config") and its size cap ``max_bytes`` [bytes]."""

    name: str
    max_bytes: int


def _mib(n: float) -> int:
    return int(n * 2**20)


CONFIG = InputKind("config", _mib(1))  # run, sweep and presets files (TOML/JSON)
LIDAR_FILE = InputKind("lidar file", _mib(1))  # a lidar description (TOML/JSON)
CONSTRAINTS = InputKind("constraint file", _mib(64))  # measured point series (JSON)
LINE_OF_SIGHT = InputKind("line-of-sight file", _mib(256))  # a v_los record (CSV or netCDF)
CSV_FILE = InputKind("CSV file", _mib(256))  # a CSV of either kind, before its header says which
MEAN_HISTORY = InputKind("mean history", _mib(64))  # hub-height speed and direction over time
PROFILE_TABLE = InputKind("profile table", _mib(1))  # z, U[, direction] rows
SPECTRUM = InputKind("spectrum file", _mib(16))  # f_hz, S_u, S_v, S_w rows (a user spectrum)
WIND_FILE = InputKind("wind file", 16 * 2**30)  # a .bts or HAWC2 box read back (turbgen fit DATA)
COHERENCE = InputKind("coherence file", _mib(16))  # f_hz, r_m, coh rows (a user yz coherence)
TOKEN = InputKind("token file", 4096)

_NOT_REGULAR = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO or pipe"), (stat.S_ISCHR, "a character device"),
                (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))  # fmt: skip


def _refuse(path, kind: InputKind, why: str) -> ParameterError:
    return ParameterError(f"{kind.name} {path}: {why}")


def _check_mode(path, kind: InputKind, st: os.stat_result) -> None:
    for is_kind, what in _NOT_REGULAR:
        if is_kind(st.st_mode):
            raise _refuse(path, kind, f"not a regular file ({what}); give a regular file")
    if st.st_size > kind.max_bytes:
        raise _too_large(path, kind, f"{st.st_size} bytes")


def _too_large(path, kind: InputKind, have: str) -> ParameterError:
    cap = kind.max_bytes
    shown = f"{cap} bytes ({cap / 2**20:g} MiB)" if cap >= 2**20 else f"{cap} bytes"
    return _refuse(path, kind, f"a {kind.name} may hold at most {shown}; it holds {have}")


def _os_error(path, kind: InputKind, exc: OSError) -> ParameterError:
    if isinstance(exc, FileNotFoundError):
        return _refuse(path, kind, "does not exist")
    return _refuse(path, kind, f"cannot read it ({exc.strerror or exc})")


def check_input(path, kind: InputKind) -> Path:
    """``path``, or ParameterError unless it is a regular file of at most ``kind.max_bytes`` (none read)."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise _os_error(path, kind, exc) from None
    _check_mode(path, kind, st)
    return Path(path)


def read_input(path, kind: InputKind) -> bytes:
    """The bytes of the regular file ``path``; ParameterError, before reading, for others or > ``kind.max_bytes``."""
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise _os_error(path, kind, exc) from None
    try:
        _check_mode(path, kind, os.fstat(fd))
        with os.fdopen(fd, "rb", closefd=False) as f:
            data = f.read(kind.max_bytes + 1)
    except OSError as exc:
        raise _os_error(path, kind, exc) from None
    finally:
        os.close(fd)
    if len(data) > kind.max_bytes:  # it grew since fstat
        raise _too_large(path, kind, "more bytes than that")
    return data


def read_input_text(path, kind: InputKind) -> str:
    """:func:`read_input` decoded as UTF-8 (ParameterError naming ``path`` when it is not UTF-8 text)."""
    data = read_input(path, kind)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _refuse(path, kind, f"not UTF-8 text (byte {exc.start})") from None
