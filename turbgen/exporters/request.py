"""What the user asked for (one validated, frozen request) and what an export produced."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError, check_int
from turbgen.exporters.shear import DEFAULT_SHEAR_EXPONENT, VerticalLayout, vertical_layout
from turbgen.spec.mean_wind import CCW_NOTE, MeanWind
from turbgen.theory import ranges

COMPONENTS = ("u", "v", "w")


@dataclass(frozen=True)
class ExportRequest:
    """Options shared by all formats; ParameterError for a non-integer ``plane``, ``hub_height_m`` out of range, or
    both ``mean_wind`` and ``shear_exponent``."""

    plane: int | None = None  # plane index (None: the rotor plane, x = 0)
    hub_height_m: float | None = None  # hub height [m] in [1, 1000] (None: the store's)
    shear_exponent: float | None = None  # power-law alpha [-] (None: DEFAULT_SHEAR_EXPONENT; no mean profile: refused)
    tower: bool = False  # add .bts tower points
    periodic: bool = True  # flag the file periodic in time
    drop_below_ground: bool = False  # drop rows at or below the ground instead of refusing
    overwrite: bool = False  # replace existing outputs
    source_label: str | None = None  # the exports' name of their source (.bts description, HDF5 ``source_store``)
    mean_wind: MeanWind | None = None  # profile, veer, hub-height history of InflowWind/HAWC2 formats (None: power law)
    runner_files: bool = False  # also the runners' input files (InflowWind .dat, HAWC2 .htc block, LidarSim section)
    notes: tuple = ()  # remarks the export adds to its own (e.g. a mean wind taken from the store's fit record)

    def source(self, fs) -> str:
        """``source_label``, else the store directory's name (not its path: the same files on any machine)."""
        if self.source_label is not None:
            return self.source_label
        return fs.path.name if getattr(fs, "path", None) is not None else fs.label

    def __post_init__(self):
        if self.plane is not None:
            # the range [0, nx - 1] depends on the store: checked in plane_index
            object.__setattr__(self, "plane", check_int("plane", self.plane, -(2**63), 2**63))
        if self.hub_height_m is not None:
            object.__setattr__(self, "hub_height_m", ranges.check("hub_height_m", self.hub_height_m))
        if self.mean_wind is not None and self.shear_exponent is not None:
            raise ParameterError("give the shear exponent either as `shear_exponent` or in `mean_wind`, not both")
        if self.mean_wind is not None and not isinstance(self.mean_wind, MeanWind):
            raise ParameterError(f"`mean_wind` = {self.mean_wind!r} is not a turbgen.spec.mean_wind.MeanWind")

    def plane_index(self, fs) -> int:
        """The plane index in [0, nx - 1] to export (default: the plane at x = 0); ParameterError if none."""
        xs = fs.grid.x_m
        if self.plane is None:
            if 0.0 not in xs:
                raise ParameterError(f"store has no rotor plane (x = 0 m) among x = {list(xs)}; choose one with `plane` 0..{len(xs) - 1}")
            return xs.index(0.0)
        if not 0 <= self.plane < len(xs):
            raise ParameterError(f"plane = {self.plane} is outside the allowed range [0, {len(xs) - 1}] (x = {list(xs)} m)")
        return self.plane

    def layout(self, fs) -> VerticalLayout:
        """Rows to export and the mean profile (:func:`turbgen.exporters.shear.vertical_layout`); ParameterError
        for a grid reaching the ground, heights the profile misses, a transient at another U or hub height."""
        hub = fs.hub_height_m if self.hub_height_m is None else self.hub_height_m
        alpha = DEFAULT_SHEAR_EXPONENT if self.shear_exponent is None else self.shear_exponent
        lay = vertical_layout(fs.grid, hub, alpha, drop_below_ground=self.drop_below_ground,
                              mean_wind=self.mean_wind)
        g = fs.grid
        event = lay.wind.transient
        if event is not None and (not np.isclose(event.V_hub_m_s, fs.U_m_s, rtol=1e-9, atol=0.0)
                                  or not np.isclose(event.hub_height_m, lay.hub_height_m, rtol=1e-9, atol=0.0)):
            raise ParameterError(f"the {event.kind} is set for V_hub {event.V_hub_m_s:g} m/s at hub height "
                                 f"{event.hub_height_m:g} m, but the field has U {fs.U_m_s:g} m/s at "
                                 f"{lay.hub_height_m:g} m: superimpose it at the field's own hub speed and height")
        lay.wind.check_record(0.0, (g.nt - 1) * g.dt_s - self.start_shift_s(fs))
        return lay

    def start_shift_s(self, fs) -> float:
        """InitX / U [s], InitX = (ny - 1) dy / 2, by which InflowWind starts a non-periodic file upstream (its
        User's Guide); 0 when periodic."""
        g = fs.grid
        return 0.0 if self.periodic else 0.5 * (g.ny - 1) * g.dy_m / fs.U_m_s


@dataclass(frozen=True)
class ExportResult:
    """Files written, the InflowWind lines that load them, remarks, and how to use each runner input file."""

    paths: tuple[Path, ...]
    inflowwind_lines: tuple[str, ...]
    notes: tuple[str, ...] = field(default=())
    usage: tuple[str, ...] = field(default=())


class Plane:
    """One yz-plane as stored (float32 fluctuations, kept rows) plus the mean wind, made full in float64 per block: with
    veer, history or transient (u, v) = rotate((U + u', v'), veer(h) + direction(t)) (turbgen.spec.mean_wind)."""

    def __init__(self, fs, ix: int, layout: VerticalLayout, first_slice_s: float = 0.0):
        self.fluct = {c: fs.read_plane(c, ix)[:, :, layout.z_first:] for c in COMPONENTS}
        self.mean_u = layout.mean_u(fs.U_m_s)
        self.nt, self.ny, self.nz = self.fluct["u"].shape
        self.wind = layout.wind
        self.varying = self.wind.varies
        self.times_s = first_slice_s + fs.grid.dt_s * np.arange(self.nt)
        self.y_m, self.heights_m = fs.grid.y(), layout.heights_m
        self.U_m_s, self.hub_height_m = fs.U_m_s, layout.hub_height_m

    def full(self, c: str, a: int = 0, b: int | None = None) -> np.ndarray:
        """Full velocity [m/s] of component ``c`` ("u", "v" or "w") for time steps a..b-1, float64 (b - a, ny, nz)."""
        v = self.fluct[c][a:b].astype(np.float64)
        if c == "u" and not self.varying:
            v += self.mean_u[None, None, :]
        if c == "w" or not self.varying:
            return v
        u, other = self.wind.full_uv(self.fluct["u"][a:b].astype(np.float64), self.fluct["v"][a:b].astype(np.float64),
                                     self.times_s[a:b, None, None], self.y_m[None, :, None],
                                     self.heights_m[None, None, :], self.U_m_s, self.hub_height_m)
        return u if c == "u" else other

    def blocks(self, bytes_per_step: int, budget: int = 1 << 24):
        """Consecutive half-open time ranges (a, b) covering 0..nt, each at most ``budget`` bytes (>= one step)."""
        step = max(1, budget // max(1, bytes_per_step))
        return [(a, min(self.nt, a + step)) for a in range(0, self.nt, step)]


def ifw_line(value, key: str, comment: str) -> str:
    """One InflowWind input-file line: ``value`` right-aligned in 20 characters (strings quoted), ``key``, comment."""
    text = f'"{value}"' if isinstance(value, (str, Path)) else (str(value) if not isinstance(value, float) else f"{value:.10g}")
    return f"{text:>20}   {key:<15} - {comment}"


def layout_notes(lay: VerticalLayout, shift_s: float, nt: int, dt_s: float) -> list[str]:
    """The summary's notes on the start shift ``shift_s`` [s], a non-default mean wind, a history or transient,
    and the rows dropped below the ground."""
    notes = [f"dropped the {lay.z_first} grid rows at or below the ground"] if lay.z_first else []
    if shift_s:
        notes.append(f"not periodic: InflowWind starts the file {shift_s:.6g} s upstream (InitX/U, half the grid "
                     f"width over U): slice k reaches the turbine at t = k*{dt_s:g} - {shift_s:.6g} s; usable "
                     f"record at the turbine 0 to {(nt - 1) * dt_s - shift_s:.6g} s")
    wind = lay.wind
    if lay.mean_wind is not None:
        notes.append(f"mean wind: {wind.describe()}")
    if wind.turns:
        notes.append(f"veer/direction turn (mean + fluctuations) per height and time, {CCW_NOTE} (+y = left looking "
                     "downwind)")
    if wind.transient is not None:
        notes.append(f"{wind.transient.describe()}, superimposed: it rides on the slices (slice k carries the event at "
                     "the time it reaches the turbine); the advection speed in the file stays the store's U, so "
                     "Taylor's shift uses the hub mean and a point X m upstream sees the event X/U s earlier")
        if not shift_s:  # periodic: InflowWind (and HAWC2) wrap the file in time
            notes.append(f"warning: the file is periodic, so the {wind.transient.kind} recurs every {nt * dt_s:g} s "
                         "record when a simulation runs longer; export with --no-periodic (periodic=False) for one "
                         "event (HAWC2 boxes are always periodic: simulate at most one record)")
    if wind.has_history:
        notes.append("the hub-height history rides on the slices (slice k carries the history at the time it "
                     "reaches the turbine); the advection speed in the file stays the store's U, so Taylor's "
                     "shift uses the hub mean and a point X m upstream sees each change X/U s earlier")
    return notes
