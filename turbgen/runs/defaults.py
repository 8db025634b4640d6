"""Paper defaults of the runs (seed paper 000 Sect. 5.1.2, neutral case; issue 3 / issue 4).

Every default of ``turbgen mann`` lives here (the CLI shows them; MannRun.from_mapping applies them).
"""

from __future__ import annotations

# Rotor (x = 0) plus the lidar range gates 50 to 170 m in steps of 13.3 m: 11 planes [m upstream].
GATES_M = tuple(round(50.0 + 13.3 * i, 9) for i in range(10))
DEFAULT_PLANES_M = (0.0, *GATES_M)

# Mann space-time model, neutral class (paper 000 Table 1 / Sect. 2.4): L [m], Gamma [-], gamma [s].
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

# Grid: 4096 samples at 0.5 s (2048 s, dx = U dt); 64 x 64 points, 4.7 m apart: a 296 m box whose lowest row stays 2 m above ground at hub height 150 m.
MANN_GRID = {"nt": 4096, "dt_s": 0.5, "x_m": DEFAULT_PLANES_M, "ny": 64, "nz": 64, "dy_m": 4.7, "dz_m": 4.7}
