"""What an exported file says about itself (for ``turbgen info FILE``): the .bts header and description,
the title and wind type of an InflowWind input file, the title of a .sum. The mean wind an export added
(profile, veer, history, transient) and a non-periodic file's start shift are in those texts."""

from __future__ import annotations

import struct
from pathlib import Path

from turbgen.errors import ParameterError
from turbgen.exporters.wnd_summary import read_sum

_BTS = struct.Struct("<h4i6f6fi")
SUFFIXES = (".bts", ".dat", ".sum")


def file_summary(path) -> list[tuple[str, str]]:
    """(label, text) rows describing an exported ``.bts``, InflowWind ``.dat`` or ``.sum`` file (ParameterError for
    an unreadable file or another kind)."""
    p = Path(path)
    rows = {".bts": _bts, ".dat": _inflowwind, ".sum": _summary}.get(p.suffix.lower())
    if rows is None:
        raise ParameterError(f"{str(p)!r} is neither a store nor a file of {', '.join(SUFFIXES)}")
    try:
        return rows(p)
    except (OSError, IndexError, struct.error, UnicodeDecodeError) as err:
        raise ParameterError(f"{str(p)!r} cannot be read as an export: {getattr(err, 'strerror', None) or err}") from None


def _summary(p: Path) -> list[tuple[str, str]]:
    """The rows of a .sum: its title and the values InflowWind parses (read as InflowWind reads them)."""
    try:
        values = read_sum(p)
    except (IndexError, ValueError, AttributeError):  # a key missing or malformed (read_sum), or not text
        raise ParameterError(f"{str(p)!r} is not a .sum InflowWind can read (no hub height, UBar and TI(u/v/w) "
                             "lines)") from None
    ti = "/".join(f"{v:g}" for v in values["ti_percent"])
    return [("file", f"{p} (.sum, {'periodic' if values['periodic'] else 'NOT periodic'})"),
            ("title", p.read_text().splitlines()[0]),
            ("wind", f"UBar {values['U_m_s']:g} m/s, hub height {values['hub_height_m']:g} m, TI u/v/w {ti} %, "
                     f"clockwise {'T' if values['clockwise'] else 'F'}")]


def _bts(p: Path) -> list[tuple[str, str]]:
    size = p.stat().st_size
    with open(p, "rb") as f:
        head = f.read(_BTS.size)
        ident, nz, ny, ntwr, nt, dz, dy, dt, uhub, zhub, zbot, *rest = _BTS.unpack(head)
        text = f.read(max(rest[-1], 0)).decode("ascii", "replace")
    if ident not in (7, 8):
        raise ParameterError(f"{str(p)!r} is not a TurbSim .bts (header ID {ident}, not 7 or 8)")
    # the velocities: int16 u, v, w at each grid point and tower point of every time step (Jonkman 2009, App. B)
    expected = _BTS.size + rest[-1] + 2 * 3 * nt * (ny * nz + ntwr)
    if min(nz, ny, nt, ntwr + 1, rest[-1] + 1) <= 0 or size != expected:
        raise ParameterError(f"{str(p)!r} is truncated or corrupted: {size} bytes, its header ({nt} x {ny} x {nz} "
                             f"points, {ntwr} tower points) needs {expected}")
    return [("file", f"{p} (TurbSim .bts, {'periodic' if ident == 8 else 'NOT periodic'})"),
            ("grid", f"(t, y, z) = {nt} x {ny} x {nz}, dt {dt:g} s, dy {dy:g} m, dz {dz:g} m, {ntwr} tower points"),
            ("wind", f"U {uhub:g} m/s (advection speed), hub height {zhub:g} m, bottom row {zbot:g} m"),
            ("description", text)]


def _inflowwind(p: Path) -> list[tuple[str, str]]:
    lines = p.read_text(errors="replace").splitlines()
    if not lines or "InflowWind" not in lines[0]:
        raise ParameterError(f"{str(p)!r} is not an InflowWind input file (first line: {lines[0][:60] if lines else ''!r})")
    keys = {}
    for line in lines[3:]:
        parts = line.split()
        if len(parts) >= 2:
            keys.setdefault(parts[1], parts[0])
    wind_type = keys.get("WindType", "?")
    file_key = {"2": "FileName_Uni", "3": "FileName_BTS", "4": "FilenameRoot", "5": "FileName_u"}.get(wind_type)
    rows = [("file", f"{p} (InflowWind input file, WindType {wind_type})"), ("title", lines[1])]
    if file_key:
        rows.append(("wind file", f"{keys.get(file_key, '?')} (relative to this file)"))
    return rows
