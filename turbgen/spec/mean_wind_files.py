"""Mean-wind options as text (``power:0.2``, ``log:z0=0.03,d=0``, ``table:FILE``) and their CSV files.

A profile table holds rows z, U [, direction], a hub-height history t, U [, direction]: comma- or
whitespace-separated numbers, one row per line, ``#`` comments and a non-numeric first line (a header)
skipped; or the same rows inline (``a,b[,c];a,b[,c]``: the service, which reads no client path).
Every reader returns the 2 or 3 columns and raises ParameterError for a row that is not numeric,
rows of different lengths or a row without 2 or 3 values; ``names`` are the columns' names for
messages, e.g. ("z (m)", "U (m/s)", "direction (deg)")."""

from __future__ import annotations

from pathlib import Path

from turbgen.errors import ParameterError
from turbgen.input_files import MEAN_HISTORY, PROFILE_TABLE, InputKind, read_input_text
from turbgen.spec.mean_wind import MeanWind


def read_columns(path, kind: InputKind, names: tuple[str, ...]) -> list[tuple[float, ...]]:
    """The columns of the CSV ``path``, a file of ``kind`` (turbgen.input_files: its name and size cap); also
    ParameterError when the file cannot be read, is not a regular file or is too large."""
    return columns_from_lines(read_input_text(path, kind).splitlines(), f"{kind.name} {str(path)!r}", names)


def inline_columns(text: str, what: str, names: tuple[str, ...]) -> list[tuple[float, ...]]:
    """The columns of rows given inline, ``"a,b[,c];a,b[,c];..."``; ``what`` names them in messages."""
    return columns_from_lines(text.split(";"), what, names, header=False)


def columns_from_lines(lines, where: str, names: tuple[str, ...], header: bool = True) -> list[tuple[float, ...]]:
    """The columns of CSV ``lines`` from ``where`` (with ``header``, a non-numeric first line is skipped)."""
    rows, header_allowed, unit = [], header, "line" if header else "row"
    for number, line in enumerate(lines, 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields = line.replace(",", " ").split()
        try:
            rows.append(tuple(float(f) for f in fields))
        except ValueError:
            if not header_allowed:
                raise ParameterError(f"{where} {unit} {number}: {line!r} is not numeric") from None
            continue  # a header line
        finally:
            header_allowed = False
        if len(rows[-1]) not in (2, 3) or len(rows[-1]) != len(rows[0]):
            raise ParameterError(f"{where} {unit} {number} has {len(rows[-1])} values; every row holds "
                                 f"{', '.join(names[:2])} [, {names[2]}]")
    if not rows:
        raise ParameterError(f"{where} holds no rows of {', '.join(names[:2])} [, {names[2]}]")
    return [tuple(c) for c in zip(*rows)]


def profile_fields(text: str, inline: bool = False) -> dict:
    """:class:`MeanWind` keyword arguments of a profile option: ``power:ALPHA``, ``log:z0=Z0[,d=D]`` or ``table:FILE``
    (``inline``: ``table:z,U[,dir];...``). ParameterError for an unknown kind, a bad value or an unreadable table."""
    kind, _, value = text.partition(":")
    kind = kind.strip().lower()
    if kind == "power":
        try:
            return {"profile": "power", "shear_exponent": float(value)}
        except ValueError:
            raise ParameterError(f"profile {text!r}: give the exponent as power:ALPHA, e.g. power:0.2") from None
    if kind == "log":
        fields = {}
        for item in filter(None, (s.strip() for s in value.split(","))):
            key, _, number = item.partition("=")
            key = key.strip().lower()
            if key not in ("z0", "d") or key in fields:
                raise ParameterError(f"profile {text!r}: give log:z0=Z0[,d=D] (metres), e.g. log:z0=0.03")
            try:
                fields[key] = float(number)
            except ValueError:
                raise ParameterError(f"profile {text!r}: {item!r} is not KEY=NUMBER") from None
        if "z0" not in fields:
            raise ParameterError(f"profile {text!r}: the log law needs z0, e.g. log:z0=0.03")
        return {"profile": "log", "roughness_m": fields["z0"], "displacement_m": fields.get("d", 0.0)}
    if kind == "table" and value:
        names = ("z (m)", "U (m/s)", "direction (deg)")
        cols = (inline_columns(value, "profile table", names) if inline
                else read_columns(value, PROFILE_TABLE, names))
        return {"profile": "table", "table_heights_m": cols[0], "table_speeds_m_s": cols[1],
                "table_directions_deg": cols[2] if len(cols) == 3 else (),
                "table_label": "inline" if inline else Path(value).name}
    table = "table:z,U[,dir];..." if inline else "table:FILE"
    raise ParameterError(f"profile {text!r} is not one of power:ALPHA, log:z0=Z0[,d=D], {table}")


def mean_wind_from_options(profile: str | None = None, veer_deg_per_m: float | None = None,
                           history=None, transient=None, *, inline: bool = False) -> MeanWind | None:
    """The MeanWind of the export options, or None when none is given (the exports' default power law): ``profile``
    as :func:`profile_fields`, ``veer_deg_per_m`` [deg/m], ``history`` a CSV of t [s], U [m/s] [, direction (deg)]
    (``inline``: its rows), ``transient`` an IecTransient. ParameterError for a bad option, file or value."""
    if profile is None and veer_deg_per_m is None and history is None and transient is None:
        return None
    fields = profile_fields(profile, inline) if profile is not None else {}
    if veer_deg_per_m is not None:
        fields["veer_deg_per_m"] = veer_deg_per_m
    if history is not None:
        names = ("t (s)", "U (m/s)", "direction (deg)")
        cols = inline_columns(history, "mean history", names) if inline else read_columns(history, MEAN_HISTORY, names)
        fields.update(history_times_s=cols[0], history_speeds_m_s=cols[1],
                      history_directions_deg=cols[2] if len(cols) == 3 else (),
                      history_label="inline" if inline else Path(history).name)
    if transient is not None:
        fields["transient"] = transient
    return MeanWind(**fields)
