"""Mean wind profile and ground clearance for the InflowWind formats.

The store holds zero-mean fluctuations with z relative to the hub. The InflowWind formats carry
the full velocity, so the exporters add a power-law mean u(h) = U (h / h_hub)^alpha at absolute
height h = h_hub + z. A grid reaching the ground (h <= 0) can carry neither the profile nor be
read by InflowWind (its grid origin is the ground): it is refused unless the rows below ground
are dropped explicitly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError, check_positive, check_range
from turbgen.grid import Grid

DEFAULT_SHEAR_EXPONENT = 0.2


@dataclass(frozen=True)
class VerticalLayout:
    """Rows ``z_first..nz-1`` of a grid placed at ``hub_height_m`` with a power-law mean.

    hub_height_m [m], shear_exponent [-], z_first: index of the lowest kept row,
    heights_m: absolute heights [m] of the kept rows (ascending).
    """

    hub_height_m: float
    shear_exponent: float
    z_first: int
    heights_m: np.ndarray

    @property
    def nz(self) -> int:
        """Number of kept rows.

        Returns
        -------
        int
            Number of kept rows.
        """
        return len(self.heights_m)

    @property
    def bottom_m(self) -> float:
        """Height of the lowest kept row [m].

        Returns
        -------
        float
            Absolute height of the lowest kept row [m].
        """
        return float(self.heights_m[0])

    @property
    def centre_m(self) -> float:
        """Height of the vertical centre of the kept rows [m].

        Returns
        -------
        float
            Midpoint of the lowest and highest kept rows [m].
        """
        return float(0.5 * (self.heights_m[0] + self.heights_m[-1]))

    def mean_u(self, U_m_s: float, heights_m=None) -> np.ndarray:
        """Power-law mean u [m/s] at ``heights_m`` (default: the kept rows).

        u(h) = U (h / hub_height_m)^shear_exponent.

        Parameters
        ----------
        U_m_s : float
            Mean wind speed at hub height [m/s].
        heights_m : array_like, optional
            Absolute heights [m]; default the kept rows (``self.heights_m``).

        Returns
        -------
        numpy.ndarray
            Mean u [m/s], shape of ``heights_m``.
        """
        h = self.heights_m if heights_m is None else np.asarray(heights_m, dtype=float)
        # power-law shear profile, u = U (h / h_hub)^alpha
        return U_m_s * (h / self.hub_height_m) ** self.shear_exponent


def vertical_layout(grid: Grid, hub_height_m, shear_exponent=DEFAULT_SHEAR_EXPONENT,
                    *, drop_below_ground: bool = False) -> VerticalLayout:
    """Check the grid against the ground and return the rows to export.

    Parameters
    ----------
    grid : Grid
        The store grid (z relative to the hub).
    hub_height_m : float
        Hub height [m], > 0.
    shear_exponent : float, optional
        Power-law exponent alpha [-] in [-1, 1]; default ``DEFAULT_SHEAR_EXPONENT`` (0.2).
    drop_below_ground : bool, optional
        Drop the rows at or below the ground (h <= 0) instead of refusing the grid.

    Returns
    -------
    VerticalLayout
        Hub height, exponent, index of the lowest kept row and the kept heights [m].

    Raises
    ------
    ParameterError
        For a non-positive hub height, an exponent outside [-1, 1], a grid reaching the ground
        without ``drop_below_ground``, or a hub height that puts every row below ground.
    """
    hub = check_positive("hub height (m)", hub_height_m)
    alpha = check_range("shear exponent", shear_exponent, -1.0, 1.0)
    heights = hub + grid.z()
    below = int(np.count_nonzero(heights <= 0.0))
    if below and not drop_below_ground:
        raise ParameterError(
            f"grid reaches the ground: hub height {hub:g} m + lowest z {grid.z()[0]:g} m = {heights[0]:g} m <= 0; "
            f"raise `hub_height` above {-grid.z()[0]:g} m or pass `drop_below_ground` to drop the {below} lowest rows")
    if below == grid.nz:
        raise ParameterError(f"hub height {hub:g} m puts every grid row below ground")
    return VerticalLayout(hub, alpha, below, heights[below:])
