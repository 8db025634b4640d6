"""The ``spectrum`` (and ``coherence``) of a Kaimal run as given (a CSV file, arrays, a mapping or a callable) -> its
LineSpectrum (LineCoherence).

The forms' meaning is in turbgen.theory.user_spectra (user_coherence). A spectrum CSV file has a header naming the
columns ``f_hz,S_u,S_v,S_w`` (any order; ``#`` lines and blank lines skipped) and one row per frequency [Hz], PSDs
in m^2/s; a coherence CSV file the columns ``f_hz,r_m,coh`` and one row per frequency [Hz] and separation [m]."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping

import numpy as np

from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.input_files import COHERENCE, SPECTRUM, InputKind, read_input_text
from turbgen.theory.user_coherence import COLUMNS as COHERENCE_COLUMNS
from turbgen.theory.user_coherence import LineCoherence, grid_separations_m
from turbgen.theory.user_spectra import COLUMNS, LineSpectrum


def _read_csv(path, kind: InputKind, columns: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Column name -> values of a CSV file of ``kind`` with a header naming ``columns`` (any order; ``#`` lines and
    blank lines skipped); ParameterError if it cannot be read, lacks the header or has a row that is not numbers."""
    text = read_input_text(path, kind)  # a regular file of at most its cap (a FIFO or device: refused)
    rows = [(n, line.strip()) for n, line in enumerate(text.splitlines(), 1)
            if line.strip() and not line.lstrip().startswith("#")]  # fmt: skip
    header = [name.strip() for name in rows[0][1].split(",")] if rows else []
    if sorted(header) != sorted(columns):
        raise ParameterError(f"{kind.name} {path}: the first line must name the columns {','.join(columns)} "
                             f"(got {','.join(header) or 'nothing'})")
    values = []
    for n, line in rows[1:]:
        cells = line.split(",")
        try:
            if len(cells) != len(columns):
                raise ValueError(f"{len(cells)} values")
            values.append([float(cell) for cell in cells])
        except ValueError as exc:
            raise ParameterError(f"{kind.name} {path}: line {n} is not {len(columns)} numbers ({exc})") from None
    table = np.array(values, dtype=float).reshape(-1, len(columns))
    return {name: table[:, i] for i, name in enumerate(header)}


def read_spectrum_csv(path) -> tuple[np.ndarray, np.ndarray]:
    """(f_hz (n,) [Hz], S (3, n) [m^2/s]) of a spectrum CSV file (columns f_hz,S_u,S_v,S_w), as written."""
    columns = _read_csv(path, SPECTRUM, COLUMNS)
    return columns["f_hz"], np.stack([columns[c] for c in COLUMNS[1:]])


def read_coherence_csv(path) -> dict:
    """The coherence table ``{f_hz (m,), r_m (n,), coh (m, n)}`` of a CSV file with one row ``f_hz,r_m,coh`` [Hz, m,
    -] per pair of its m frequencies and n separations (any order); ParameterError for a pair missing or repeated."""
    columns = _read_csv(path, COHERENCE, COHERENCE_COLUMNS)
    (f, i), (r, j) = (np.unique(columns[c], return_inverse=True) for c in COHERENCE_COLUMNS[:2])
    coh = np.full((f.size, r.size), np.nan)
    coh[i, j] = columns["coh"]
    if i.size != f.size * r.size or np.isnan(coh).any():
        raise ParameterError(f"coherence file {path}: {i.size} rows for {f.size} frequencies x {r.size} separations; "
                             "needs one row per pair (f_hz, r_m)")
    return {"f_hz": f, "r_m": r, "coh": coh}


def line_spectrum(value, grid: Grid) -> LineSpectrum | None:
    """The band means of ``value`` on ``grid``'s lines (None: no user spectrum): a CSV path, a mapping of ``f_hz``,
    ``S_u``, ``S_v``, ``S_w`` (a store's record), four arrays, a callable ``S(f_hz) -> (3, n)`` [m^2/s] or a
    LineSpectrum of the same record. ParameterError for anything else or what LineSpectrum refuses."""
    if value is None:
        return None
    if isinstance(value, LineSpectrum):
        if (value.nt, value.dt_s) != (grid.nt, grid.dt_s):
            raise ParameterError(f"spectrum: made for nt {value.nt}, dt {value.dt_s:g} s; the run has nt {grid.nt}, "
                                 f"dt {grid.dt_s:g} s")
        return value
    if isinstance(value, (str, os.PathLike)):
        f, S = read_spectrum_csv(value)
    elif isinstance(value, Mapping):
        if set(value) != set(COLUMNS):
            raise ParameterError(f"spectrum mapping: keys {', '.join(sorted(map(str, value)))}; needs exactly "
                                 f"{', '.join(COLUMNS)}")
        f, S = value["f_hz"], [value[c] for c in COLUMNS[1:]]
    elif isinstance(value, Callable):
        return LineSpectrum.from_callable(value, grid.nt, grid.dt_s)
    else:
        try:
            f, *S = value
        except (TypeError, ValueError):
            raise ParameterError(f"spectrum: {type(value).__name__} is not a CSV path, a mapping or arrays of "
                                 f"{', '.join(COLUMNS)}, or a callable S(f_hz) -> (3, n)") from None
    try:
        f, S = np.asarray(f, dtype=float), np.asarray(S, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"spectrum: the table is not numbers ({exc})") from None
    return LineSpectrum.from_table(f, S, grid.nt, grid.dt_s)


def line_coherence(value, grid: Grid, U_m_s: float) -> LineCoherence | None:
    """The LineCoherence the run samples (turbgen.theory.user_coherence) of ``value`` on ``grid``'s lines (None: the
    IEC exponential): a mapping of ``f_hz``, ``r_m``, ``coh`` (a store's record), a CSV file of it
    (:func:`read_coherence_csv`), or a callable ``coh(f_hz, r_m, U_m_s [m/s])`` [-] evaluated on the lines x the
    grid's separations. ParameterError for anything else or what LineCoherence refuses."""
    if value is None or isinstance(value, LineCoherence) and (value.nt, value.dt_s) == (grid.nt, grid.dt_s):
        return value
    if isinstance(value, (str, os.PathLike)):
        value = read_coherence_csv(value)
    if isinstance(value, Mapping) and set(value) == set(COHERENCE_COLUMNS):
        return LineCoherence.from_table(value["f_hz"], value["r_m"], value["coh"], grid.nt, grid.dt_s)
    if callable(value) and not isinstance(value, LineCoherence):
        r_m = grid_separations_m(grid.ny, grid.nz, grid.dy_m, grid.dz_m)
        return LineCoherence.from_callable(value, grid.nt, grid.dt_s, r_m, U_m_s)
    raise ParameterError(f"coherence: {type(value).__name__} is not a CSV path, a mapping of "
                         f"{', '.join(COHERENCE_COLUMNS)} nor a callable coh(f_hz, r_m, U_m_s), or was made for "
                         "another nt, dt")
