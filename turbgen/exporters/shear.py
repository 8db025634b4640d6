"""Mean wind profile and ground clearance for the InflowWind formats (a grid reaching the ground is refused
unless its rows below are dropped)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError, check_positive
from turbgen.grid import Grid
from turbgen.spec.mean_wind import DEFAULT_SHEAR_EXPONENT, MeanWind


@dataclass(frozen=True)
class VerticalLayout:
    """Rows ``z_first..nz-1`` (absolute ``heights_m`` [m]) of a grid at ``hub_height_m`` [m] with a mean wind
    (None: the power law with ``shear_exponent`` [-])."""

    hub_height_m: float
    shear_exponent: float
    z_first: int
    heights_m: np.ndarray
    mean_wind: MeanWind | None = None

    @property
    def wind(self) -> MeanWind:
        """The mean wind (the power law with ``shear_exponent`` when none was given)."""
        return self.mean_wind if self.mean_wind is not None else MeanWind(shear_exponent=self.shear_exponent)

    @property
    def nz(self) -> int:
        """Number of kept rows."""
        return len(self.heights_m)

    @property
    def bottom_m(self) -> float:
        """Height of the lowest kept row [m]."""
        return float(self.heights_m[0])

    @property
    def centre_m(self) -> float:
        """Height of the vertical centre of the kept rows [m]."""
        return float(0.5 * (self.heights_m[0] + self.heights_m[-1]))

    def mean_u(self, U_m_s: float, heights_m=None) -> np.ndarray:
        """Mean speed U(h) [m/s] at ``heights_m`` (default: the kept rows), before any veer."""
        h = self.heights_m if heights_m is None else np.asarray(heights_m, dtype=float)
        return U_m_s * self.wind.speed_ratio(h, self.hub_height_m)


def vertical_layout(grid: Grid, hub_height_m, shear_exponent=DEFAULT_SHEAR_EXPONENT,
                    *, drop_below_ground: bool = False, mean_wind: MeanWind | None = None) -> VerticalLayout:
    """Check ``grid`` (z relative to the hub) at ``hub_height_m`` [m] against the ground; the rows to export with
    the power law of ``shear_exponent`` [-] or ``mean_wind``. ``drop_below_ground``: drop the rows at h <= 0
    instead of refusing (ParameterError), as for heights the profile does not cover."""
    hub = check_positive("hub height (m)", hub_height_m)
    wind = mean_wind if mean_wind is not None else MeanWind(shear_exponent=shear_exponent)
    heights = hub + grid.z()
    below = int(np.count_nonzero(heights <= 0.0))
    if below and not drop_below_ground:
        raise ParameterError(
            f"grid reaches the ground: hub height {hub:g} m + lowest z {grid.z()[0]:g} m = {heights[0]:g} m <= 0; "
            f"raise `hub_height` above {-grid.z()[0]:g} m or pass `drop_below_ground` to drop the {below} lowest rows")
    if below == grid.nz:
        raise ParameterError(f"hub height {hub:g} m puts every grid row below ground")
    kept = heights[below:]
    wind.speed_ratio(kept, hub)  # refuses heights the profile does not cover, before anything is written
    wind.veer_deg(kept, hub)
    return VerticalLayout(hub, wind.shear_exponent, below, kept, mean_wind)
