"""The points of the grid the validator compares: yz separations, the rotor disc, the plane-pair sub-lattice."""

from __future__ import annotations

import math

import numpy as np

from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.spec.defaults import DEFAULT_ROTOR_RADIUS_M
from turbgen.theory import ranges

LONG_POINTS_PER_AXIS = 16  # sub-lattice for the plane-pair cross-spectra: at most 16 x 16 points per plane ...


def grid_steps(sep_m: float, step_m: float, n: int) -> int:
    """A separation ``sep_m`` [m] in whole grid steps ``step_m`` [m], clipped to [0, n // 2] (>= 1 if positive)."""
    return int(min(max(round(sep_m / step_m), 1 if sep_m > 0 else 0), n // 2))


def default_separations(grid: Grid) -> tuple[tuple[int, int], ...]:
    """(lateral, vertical) separations in grid steps: ~10 m and ~30 m lateral and vertical, ~20 m diagonal."""
    seps = []
    for dy_m, dz_m in ((10.0, 0.0), (30.0, 0.0), (0.0, 10.0), (0.0, 30.0), (20.0, 20.0)):
        a, b = grid_steps(dy_m, grid.dy_m, grid.ny), grid_steps(dz_m, grid.dz_m, grid.nz)
        if (a, b) != (0, 0) and (a, b) not in seps and (dy_m == 0 or a > 0) and (dz_m == 0 or b > 0):
            seps.append((a, b))
    return tuple(seps)


def rotor_mask(grid: Grid, radius_m: float) -> np.ndarray:
    """(ny, nz) bool: grid points in the rotor disc of radius ``radius_m`` [m] about the hub; ParameterError if none."""
    y, z = grid.y(), grid.z()
    mask = y[:, None] ** 2 + z[None, :] ** 2 <= radius_m**2 * (1 + 1e-12)
    if not mask.any():
        raise ParameterError(f"rotor radius = {radius_m:g} m contains no grid point (dy = {grid.dy_m:g} m)")
    return mask


def check_rotor_radius(grid: Grid, radius_m: float | None) -> float:
    """The rotor radius R [m]: 0 < R <= half the smaller grid extent, else ParameterError; None: 63 m (NREL 5 MW,
    Jonkman et al. 2009), or the largest disc a smaller grid holds."""
    half = min((grid.ny - 1) * grid.dy_m, (grid.nz - 1) * grid.dz_m) / 2.0
    if radius_m is None:
        nearest = float(np.hypot(grid.y()[:, None], grid.z()[None, :]).min())
        return max(min(DEFAULT_ROTOR_RADIUS_M, half), nearest)
    r = float(radius_m)
    if math.isfinite(r) and r > 0:
        ranges.check("rotor_radius_m", r)
    if not (math.isfinite(r) and 0 < r <= half * (1 + 1e-9)):
        raise ParameterError(f"rotor radius = {radius_m!r} m is outside the grid's range (0, {half:g}] m")
    return r


def long_sublattice(n: int, per_axis: int = LONG_POINTS_PER_AXIS) -> np.ndarray:
    """Indices of an evenly strided sub-lattice of at most ``per_axis`` points (centred)."""
    stride = max(1, math.ceil(n / per_axis))
    idx = np.arange(0, n, stride)
    return idx + (n - 1 - idx[-1]) // 2
