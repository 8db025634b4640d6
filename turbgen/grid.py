"""The 4D grid (t, x, y, z) shared by generators, stores and exports.

t [s]: eddy (convected-frame) time, t = n dt, n = 0..nt-1.
x [m]: upstream distance of each yz-plane from the rotor (rotor = 0, positive upstream).
y [m]: lateral, +y to the left looking downwind (InflowWind convention), centred on the hub.
z [m]: vertical, relative to hub height (positive up), centred on the hub."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError, check_finite, check_int, check_positive


@dataclass(frozen=True)
class Grid:
    """Regular 4D grid. ``x_m`` holds the plane positions [m] in the order they are stored."""

    nt: int
    dt_s: float
    x_m: tuple[float, ...]
    ny: int
    nz: int
    dy_m: float
    dz_m: float

    def __post_init__(self):
        object.__setattr__(self, "nt", check_int("nt", self.nt, 2, 2**24))
        object.__setattr__(self, "dt_s", check_positive("dt (s)", self.dt_s))
        object.__setattr__(self, "ny", check_int("ny", self.ny, 1, 2**14))
        object.__setattr__(self, "nz", check_int("nz", self.nz, 1, 2**14))
        object.__setattr__(self, "dy_m", check_positive("dy (m)", self.dy_m))
        object.__setattr__(self, "dz_m", check_positive("dz (m)", self.dz_m))
        xs = tuple(check_finite("plane position x (m)", x) for x in self.x_m)
        if not xs:
            raise ParameterError("planes: at least one plane position is needed")
        if len(set(xs)) != len(xs):
            raise ParameterError(f"planes = {list(xs)} contain a duplicate position")
        object.__setattr__(self, "x_m", xs)

    @property
    def nx(self) -> int:
        """Number of yz-planes."""
        return len(self.x_m)

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """(nt, nx, ny, nz)."""
        return (self.nt, self.nx, self.ny, self.nz)

    def t(self) -> np.ndarray:
        """Time coordinate [s], float64."""
        return np.arange(self.nt) * self.dt_s

    def x(self) -> np.ndarray:
        """Plane positions [m upstream of the rotor], float64."""
        return np.asarray(self.x_m, dtype=float)

    def y(self) -> np.ndarray:
        """Lateral coordinate [m], centred on the hub."""
        return (np.arange(self.ny) - (self.ny - 1) / 2.0) * self.dy_m

    def z(self) -> np.ndarray:
        """Vertical coordinate relative to hub height [m], centred on the hub."""
        return (np.arange(self.nz) - (self.nz - 1) / 2.0) * self.dz_m

    def nbytes_per_component(self, itemsize: int = 4) -> int:
        """Bytes of one component of the whole field."""
        return self.nt * self.nx * self.ny * self.nz * itemsize
