"""What the user asked for (one validated, frozen request) and what an export produced."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError, check_int, check_positive
from turbgen.export.shear import DEFAULT_SHEAR_EXPONENT, VerticalLayout, vertical_layout

COMPONENTS = ("u", "v", "w")


@dataclass(frozen=True)
class ExportRequest:
    """Options shared by all formats.

    plane: index into the store's planes (None = the rotor plane, x = 0);
    hub_height_m: overrides the store's hub height [m]; shear_exponent: power-law alpha [-];
    tower: add .bts tower points; periodic: flag the file periodic in time (InflowWind wraps);
    drop_below_ground: drop grid rows at or below the ground instead of refusing;
    overwrite: replace existing outputs.
    """

    plane: int | None = None
    hub_height_m: float | None = None
    shear_exponent: float = DEFAULT_SHEAR_EXPONENT
    tower: bool = False
    periodic: bool = True
    drop_below_ground: bool = False
    overwrite: bool = False

    def __post_init__(self):
        if self.plane is not None:
            # the range [0, nx - 1] depends on the store: checked in plane_index
            object.__setattr__(self, "plane", check_int("plane", self.plane, -(2**63), 2**63))
        if self.hub_height_m is not None:
            object.__setattr__(self, "hub_height_m", check_positive("hub height (m)", self.hub_height_m))

    def plane_index(self, fs) -> int:
        """The plane to export from store ``fs`` (default: the plane at x = 0)."""
        xs = fs.grid.x_m
        if self.plane is None:
            if 0.0 not in xs:
                raise ParameterError(f"store has no rotor plane (x = 0 m) among x = {list(xs)}; choose one with `plane` 0..{len(xs) - 1}")
            return xs.index(0.0)
        if not 0 <= self.plane < len(xs):
            raise ParameterError(f"plane = {self.plane} is outside the allowed range [0, {len(xs) - 1}] (x = {list(xs)} m)")
        return self.plane

    def layout(self, fs) -> VerticalLayout:
        """Rows to export and the mean profile, for store ``fs``."""
        hub = fs.hub_height_m if self.hub_height_m is None else self.hub_height_m
        return vertical_layout(fs.grid, hub, self.shear_exponent, drop_below_ground=self.drop_below_ground)


@dataclass(frozen=True)
class ExportResult:
    """Files written, the InflowWind input-file lines that load them, and remarks for the user."""

    paths: tuple[Path, ...]
    inflowwind_lines: tuple[str, ...]
    notes: tuple[str, ...] = field(default=())


class Plane:
    """One yz-plane as stored (float32 fluctuations, kept rows only) plus the power-law mean of
    u; full velocities are made in float64 one time block at a time, so memory stays at about
    one stored plane."""

    def __init__(self, fs, ix: int, layout: VerticalLayout):
        self.fluct = {c: fs.read_plane(c, ix)[:, :, layout.z_first:] for c in COMPONENTS}
        self.mean_u = layout.mean_u(fs.U_m_s)
        self.nt, self.ny, self.nz = self.fluct["u"].shape

    def full(self, c: str, a: int = 0, b: int | None = None) -> np.ndarray:
        """Full velocity [m/s] of component ``c`` for time steps a..b-1, float64 (b - a, ny, nz)."""
        v = self.fluct[c][a:b].astype(np.float64)
        if c == "u":
            v += self.mean_u[None, None, :]
        return v

    def blocks(self, bytes_per_step: int, budget: int = 1 << 24):
        """(a, b) time blocks of at most ``budget`` bytes at ``bytes_per_step`` each."""
        step = max(1, budget // max(1, bytes_per_step))
        return [(a, min(self.nt, a + step)) for a in range(0, self.nt, step)]


def ifw_line(value, key: str, comment: str) -> str:
    """One InflowWind input-file line: value, key name (second token), description."""
    text = f'"{value}"' if isinstance(value, (str, Path)) else (str(value) if not isinstance(value, float) else f"{value:.10g}")
    return f"{text:>20}   {key:<15} - {comment}"
