"""turbgen: 4D stochastic wind-turbulence fields u(t, x, y, z).

Mann (1994) space-time generator (Guo et al. 2022) and Kaimal/IEC generator with
direct-product longitudinal coherence (evoTurb style), zarr stores, validation against
theory, and exports for OpenFAST / HAWC2 / lidar simulators.
"""

__version__ = "0.1.0"
