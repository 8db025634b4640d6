"""The allowed range of every physical input parameter and the size limit of every list: one table.

Values outside are refused with one line naming the value and the range (``ParameterError``; CLI exit
code 2) before anything is computed. The ranges are what the models are meant for (atmospheric
boundary layer, wind-turbine and lidar scales), not what happens to compute. docs/store.md ("Limits
and ranges") shows the table; tests/cli/test_bad_input.py checks every bound is enforced."""

from __future__ import annotations

import math
from dataclasses import dataclass

from turbgen.errors import ParameterError, check_int, check_range


@dataclass(frozen=True)
class Range:
    """Closed interval [lo, hi] (open at ``lo`` when ``lo_open``) of one parameter, in SI units; ``label`` names it
    in messages (option and unit), ``why`` is one phrase for the README table."""

    label: str
    lo: float
    hi: float
    why: str
    lo_open: bool = False
    integer: bool = False

    def check(self, value, label: str | None = None):
        """``value`` as float (int for integer ranges), or ParameterError naming it (or ``label``) and the range."""
        if self.integer:
            return check_int(label or self.label, value, int(self.lo), int(self.hi))
        return check_range(label or self.label, value, self.lo, self.hi, lo_open=self.lo_open)

    def text(self) -> str:
        """The range as text, '[lo, hi]' or '(lo, hi]'."""
        if self.integer:
            return f"[{int(self.lo)}, {int(self.hi)}]"
        return f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"


RANGES: dict[str, Range] = {
    # mean flow and run metadata
    "U_m_s": Range("U (mean wind speed, m/s)", 0.5, 100.0, "mean wind at hub height"),
    "hub_height_m": Range("hub height (m)", 1.0, 1000.0, "within the atmospheric boundary layer"),
    "seed": Range("seed", 0, 2**63 - 1, "64-bit SeedSequence entropy", integer=True),
    "pad_yz": Range("pad-yz", 1, 8, "synthesis box width / output width", integer=True),
    # Mann model (Mann 1994; Guo et al. 2022)
    # ae >= 1e-6: eps = 4e-10 m^2/s^3, far below the calmest measured boundary layers (~1e-6 m^2/s^3)
    "ae": Range("ae (alpha*eps^(2/3), m^(4/3)/s^2)", 1e-6, 100.0, "spectral energy level (eps >= 4e-10 m^2/s^3)"),
    "length_scale_m": Range("L (length scale, m)", 1.0, 1000.0, "energy-containing eddies of the ABL"),
    "gamma": Range("gamma (Gamma, -)", 0.0, 20.0, "shear anisotropy (0 = isotropic)"),
    "evo_time_s": Range("evo (gamma, s)", 1.0, 1e5, "eddy evolution time (or 'frozen')"),
    "factor1": Range("factor1", 0.0, 3.0, "small-k slope of the Guo lifetime", lo_open=True),
    "factor2": Range("factor2", 0.0, 10.0, "large-k slope of the evolution lifetime", lo_open=True),
    "sigma_u_m_s": Range("sigma-u (m/s)", 0.001, 30.0, "target standard deviation of u"),
    "ti": Range("ti (turbulence intensity, -)", 0.0, 1.0, "sigma_u / U", lo_open=True),
    # Kaimal / IEC model (IEC 61400-1; Guo et al. 2023, Eq. 11-12, 18)
    "sigma_m_s": Range("sigma (m/s)", 0.001, 30.0, "each of sigma_u, sigma_v, sigma_w"),
    "length_scales_m": Range("lengths (Kaimal L, m)", 0.1, 10000.0, "each of L1, L2, L3"),
    "a_yz": Range("ayz (a_yz, -)", 0.0, 1e4, "yz coherence decay (1e4: incoherent)"),
    "lc_m": Range("lc (Lc, m)", 0.1, 10000.0, "yz coherence scale"),
    "a_x": Range("ax (a_x, -)", 0.0, 100.0, "longitudinal coherence decay", lo_open=True),
    "b_x": Range("bx (b_x, 1/m)", 0.0, 1.0, "longitudinal coherence distance term"),
    # grid of a run (the store's Grid itself only needs to be consistent)
    "nt": Range("nt", 2, 2**24, "time samples", integer=True),
    "dt_s": Range("dt (s)", 0.001, 60.0, "time step (dx = U dt for Mann)"),
    "ny": Range("ny", 2, 4096, "lateral points", integer=True),
    "nz": Range("nz", 2, 4096, "vertical points", integer=True),
    "dy_m": Range("dy (m)", 0.01, 1000.0, "lateral spacing"),
    "dz_m": Range("dz (m)", 0.01, 1000.0, "vertical spacing"),
    "x_m": Range("planes (x, m upstream)", 0.0, 10000.0, "rotor 0, positive upstream; increasing"),
    # measurements a field is conditioned on: fluctuations or total wind, point series and lidar v_los
    "measured_m_s": Range("measured wind (m/s)", -150.0, 150.0, "each constraint value (record gust: 113 m/s)"),
    # theory evaluation points and separations
    "separation_m": Range("separation (m)", 0.0, 10000.0, "dx, dy, dz of `turbgen theory` / `fit`"),
    "rotor_radius_m": Range("rotor radius (m)", 0.5, 500.0, "rotor-effective wind speed disc"),
    "f_hz": Range("f (Hz)", 0.0, 1000.0, "frequency", lo_open=True),
    "k1_rad_m": Range("k1 (rad/m)", 0.0, 1e4, "longitudinal wavenumber", lo_open=True),
}

# Maximum number of entries of every list-valued input; a longer list is refused before it is built.
LIMITS: dict[str, int] = {
    "planes": 256,  # planes (or 1 + gates) of one field
    "seeds": 10_000,  # seeds of one sweep
    "speeds": 200,  # wind speeds of one sweep
    "runs": 10_000,  # fields of one sweep (models x presets x speeds x seeds)
    "points": 100_000,  # --f / --k1 evaluation points of `turbgen theory`
    "threads": 256,  # --threads of one run (never changes the field)
    "workers": 256,  # --workers of a sweep's local cluster
}


def check(key: str, value, label: str | None = None):
    """``value`` checked against ``RANGES[key]`` (as :meth:`Range.check`; ``label`` names it in the message)."""
    return RANGES[key].check(value, label)


def check_values(key: str, values, where: str) -> None:
    """Check every value of an array against ``RANGES[key]`` (NaN, a missing value, passes; +-inf does not);
    ParameterError "<where>: <label> = <value> (index i) is ..." for the first value outside."""
    import numpy as np

    r = RANGES[key]
    v = np.asarray(values, dtype=float)
    bad = ~np.isnan(v) & ~((v >= r.lo) & (v <= r.hi))
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        try:
            r.check(float(v[index]))
        except ParameterError as exc:
            shown = index[0] if len(index) == 1 else index
            raise ParameterError(f"{where}: {exc} (index {shown})") from None


def check_count(key: str, n: int, what: str | None = None) -> int:
    """``n``, or ParameterError if a list of ``n`` entries (named ``what``) is longer than ``LIMITS[key]``."""
    limit = LIMITS[key]
    if n > limit:
        raise ParameterError(f"{what or key}: {n} values is more than the maximum {limit}")
    return n


def count_text(n: float) -> str:
    """A count for a message: exact up to 10^12, else three digits and the power of ten ("about 1e+300"; ``n`` may
    be an int beyond the float range)."""
    if n <= 10**12:
        return str(int(n))
    e = math.floor(math.log10(n))
    return f"about {n / 10**e:.3g}e+{e}"


def parse_ints(text: str, key: str = "seeds") -> list[int]:
    """'1-21' or '1,4,7' or '1-3,9' -> sorted unique non-negative ints; ParameterError for an empty entry, a
    non-integer, a backward range or more than ``LIMITS[key]`` values (counted before any range is expanded)."""
    parts = [p.strip() for p in text.split(",")]
    if text.strip() and not all(parts):  # '1,,3': a value left out
        raise ParameterError(f"{text!r} has an empty entry (write integers separated by single commas)")
    spans: list[tuple[int, int]] = []
    for part in filter(None, parts):
        lo, sep, hi = part.partition("-")
        try:
            lo_i, hi_i = int(lo), int(hi) if sep else int(lo)
        except ValueError:
            raise ParameterError(f"{part!r} in {text!r} is not a non-negative integer or a range like 1-21") from None
        if hi_i < lo_i:
            raise ParameterError(f"range {part!r} runs backwards (write {hi_i}-{lo_i})")
        spans.append((lo_i, hi_i))
    if not spans:
        raise ParameterError(f"{text!r} holds no integer")
    count = sum(hi - lo + 1 for lo, hi in spans)
    if count > LIMITS[key]:
        raise ParameterError(f"{text!r} gives {count_text(count)} values, more than the maximum {LIMITS[key]}")
    return sorted(set().union(*(range(lo, hi + 1) for lo, hi in spans)))


def check_grid(grid) -> None:
    """Check a run's grid (turbgen.grid.Grid) against the table: sizes, spacings, planes.

    Plane positions must lie in the x range and increase strictly (stores and readers rely on sorted x;
    a negative x would be downstream of the rotor). Raises ParameterError otherwise."""
    for key in ("nt", "dt_s", "ny", "nz", "dy_m", "dz_m"):
        check(key, getattr(grid, key))
    xs = list(grid.x_m)
    check_count("planes", len(xs))
    for x in xs:
        check("x_m", x)
    if any(b <= a for a, b in zip(xs, xs[1:])):
        raise ParameterError(f"planes = {', '.join(f'{x:g}' for x in xs)} must be in increasing order (e.g. 0,50,100)")


def markdown_table() -> str:
    """The README table (parameter, allowed range, note), one row per RANGES and per LIMITS entry."""
    rows = ["| parameter | allowed range | note |", "|---|---|---|"]
    rows += [f"| {r.label} | {r.text()} | {r.why} |" for r in RANGES.values()]
    rows += [f"| number of {k} | at most {v:,} | |" for k, v in LIMITS.items()]
    return "\n".join(rows)


__all__ = ["LIMITS", "RANGES", "Range", "check", "check_count", "check_grid", "check_values", "markdown_table"]
