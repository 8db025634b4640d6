"""Defaults of every run (Guo et al. 2023, Sect. 5.1.2, neutral case) and the grid rule "dz defaults to dy".

The commands show these values in their help, ``MannRun.from_mapping`` / ``KaimalRun.from_mapping``
apply them, and the sweep plans with them: they are written nowhere else."""

from __future__ import annotations

from collections.abc import Mapping

from turbgen.grid import Grid
from turbgen.theory import ranges

# Rotor (x = 0) plus the lidar range gates 50 to 170 m in steps of 13.3 m: 11 planes [m upstream].
GATES_M = tuple(round(50.0 + 13.3 * i, 9) for i in range(10))
DEFAULT_PLANES_M = (0.0, *GATES_M)
# The validator's rotor-effective wind: the NREL 5 MW reference turbine (Jonkman et al. 2009), as in Guo et al. 2023.
DEFAULT_ROTOR_RADIUS_M = 63.0

# Mann space-time model, neutral class (Guo et al. 2023, Table 1 and Sect. 2.4): L [m], Gamma [-], gamma [s].
MANN_DEFAULTS = {
    "U_m_s": 16.0,  # mean wind speed [m/s]
    "length_scale_m": 49.0,
    "gamma": 3.1,
    "evo_time_s": 400.0,
    "lifetime": "guo",
    "factor1": 1.0,
    "factor2": 3.5,
    "turb_class": "A",  # alpha*eps^(2/3) set so the model sigma_u is the IEC NTM sigma_1 of this class at U
    "seed": 1,
    "hub_height_m": 150.0,  # keeps a ~300 m box above the ground (metadata for exports)
    "pad_yz": 2,  # synthesise a box 2x wider in y and z and crop (periodicity of Mann boxes)
}

# Grid: 4096 samples at 0.5 s (2048 s, dx = U dt); 64 x 64 points, 4.7 m apart: a 296 m box whose
# lowest row stays 2 m above ground at hub height 150 m.
MANN_GRID = {"nt": 4096, "dt_s": 0.5, "x_m": DEFAULT_PLANES_M, "ny": 64, "nz": 64, "dy_m": 4.7}

# Kaimal 4D field: IEC class A NTM at 16 m/s, exponential longitudinal coherence (Guo et al. 2023,
# Eq. 18) with the neutral Table 2 constants for gamma = 400 s: a_x [-], b_x [1/m].
DEFAULT_A_X = 1.8
DEFAULT_B_X = 1.49e-4
KAIMAL_DEFAULTS = {
    "U_m_s": 16.0,
    "turb_class": "A",
    # the same default hub height as Mann's (which needs it for its 296 m box): no Kaimal statistic changes with it
    # (IEC Lambda1 = 42 m at every hub height above 60 m), only the heights the exports write
    "hub_height_m": 150.0,
    "long_model": "exp",
    "long_components": "u",
    "vw_coherence": "white",
    "rescale": False,
    "seed": 1,
}
# 4096 x 11 x 31 x 31 samples, dt 0.5 s, a 150 m x 150 m plane
KAIMAL_GRID = {"nt": 4096, "dt_s": 0.5, "x_m": DEFAULT_PLANES_M, "ny": 31, "nz": 31, "dy_m": 5.0}


def grid_from_mapping(given: Mapping | Grid | None, defaults: Mapping) -> Grid:
    """The grid of a run mapping's ``grid`` table (or a Grid, returned as is): missing keys take ``defaults``
    (MANN_GRID or KAIMAL_GRID), dz_m defaults to dy_m. ParameterError outside the run's ranges (turbgen.theory.ranges,
    tighter than the store grid's)."""
    if isinstance(given, Grid):
        return given
    g = {**defaults, **(given or {})}
    for key in ("nt", "dt_s", "ny", "nz", "dy_m", "dz_m"):  # the run's ranges, before Grid's looser store checks
        if g.get(key) is not None:
            ranges.check(key, g[key])
    return Grid(g["nt"], g["dt_s"], tuple(g["x_m"]), g["ny"], g["nz"], g["dy_m"], g.get("dz_m", g["dy_m"]))
