"""Mean-wind options as text: ``power:0.2``, ``log:z0=0.03,d=0``, ``table:FILE`` and the CSV files
of a profile table (z, U [, direction]) and of a hub-height history (t, U [, direction]).

CSV files: comma- or whitespace-separated numbers, one row per line; lines starting with ``#`` and
a first line that is not numeric (a header) are skipped.
"""

from __future__ import annotations

from pathlib import Path

from turbgen.errors import ParameterError
from turbgen.spec.mean_wind import MeanWind


def read_columns(path, what: str, names: tuple[str, ...]) -> list[tuple[float, ...]]:
    """The columns of the CSV ``path``: 2 or 3 numbers per row.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    what : str
        What the file is (for messages), e.g. "profile table".
    names : tuple of str
        Column names (for messages), e.g. ("z (m)", "U (m/s)", "direction (deg)").

    Returns
    -------
    list of tuple of float
        The columns (2 or 3).

    Raises
    ------
    ParameterError
        When the file cannot be read, a row is not numeric, rows differ in length or a row does not
        hold 2 or 3 values.
    """
    try:
        text = Path(path).read_text()
    except (OSError, UnicodeDecodeError) as err:
        raise ParameterError(f"{what} {str(path)!r} cannot be read: {getattr(err, 'strerror', None) or err}") from None
    rows, header_allowed = [], True
    for number, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields = line.replace(",", " ").split()
        try:
            rows.append(tuple(float(f) for f in fields))
        except ValueError:
            if not header_allowed:
                raise ParameterError(f"{what} {str(path)!r} line {number}: {line!r} is not numeric") from None
            continue  # a header line
        finally:
            header_allowed = False
        if len(rows[-1]) not in (2, 3) or len(rows[-1]) != len(rows[0]):
            raise ParameterError(f"{what} {str(path)!r} line {number} has {len(rows[-1])} values; every row holds "
                                 f"{', '.join(names[:2])} [, {names[2]}]")
    if not rows:
        raise ParameterError(f"{what} {str(path)!r} holds no rows of {', '.join(names[:2])} [, {names[2]}]")
    return [tuple(c) for c in zip(*rows)]


def profile_fields(text: str) -> dict:
    """MeanWind fields of a profile option: ``power:ALPHA``, ``log:z0=Z0[,d=D]`` or ``table:FILE``.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    dict
        Keyword arguments of :class:`MeanWind` (the table read from its file).

    Raises
    ------
    ParameterError
        For an unknown kind, a malformed value or an unreadable table.
    """
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
        cols = read_columns(value, "profile table", ("z (m)", "U (m/s)", "direction (deg)"))
        return {"profile": "table", "table_heights_m": cols[0], "table_speeds_m_s": cols[1],
                "table_directions_deg": cols[2] if len(cols) == 3 else (), "table_label": Path(value).name}
    raise ParameterError(f"profile {text!r} is not one of power:ALPHA, log:z0=Z0[,d=D], table:FILE")


def mean_wind_from_options(profile: str | None = None, veer_deg_per_m: float | None = None,
                           history=None, transient=None) -> MeanWind | None:
    """The MeanWind of the export options, or None when none is given (the exports' default power law).

    Parameters
    ----------
    profile : str, optional
        ``power:ALPHA``, ``log:z0=Z0[,d=D]`` or ``table:FILE`` (default: power law, alpha 0.2).
    veer_deg_per_m : float, optional
        Linear veer rate [deg/m].
    history : str or os.PathLike, optional
        CSV of t [s], U [m/s] [, direction (deg)] at hub height.
    transient : IecTransient, optional
        An IEC transient to superimpose.

    Returns
    -------
    MeanWind or None
        None when no option is given.

    Raises
    ------
    ParameterError
        For a malformed option, an unreadable file or values outside their ranges.
    """
    if profile is None and veer_deg_per_m is None and history is None and transient is None:
        return None
    fields = profile_fields(profile) if profile is not None else {}
    if veer_deg_per_m is not None:
        fields["veer_deg_per_m"] = veer_deg_per_m
    if history is not None:
        cols = read_columns(history, "mean history", ("t (s)", "U (m/s)", "direction (deg)"))
        fields.update(history_times_s=cols[0], history_speeds_m_s=cols[1],
                      history_directions_deg=cols[2] if len(cols) == 3 else (), history_label=Path(history).name)
    if transient is not None:
        fields["transient"] = transient
    return MeanWind(**fields)
