"""The periodic synthesis box of a Mann (1998) field: its size, spacings and wavenumbers.

The real FFT runs along xi = -U t (Taylor), so the stored slab of FFT index i holds k1 = -i dk1."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.theory.lattice import k2_wavenumbers, k3_wavenumbers


@dataclass(frozen=True)
class BoxShape:
    """The synthesis box: nt samples along xi spaced dx_m [m], nyp x nzp (padded) spaced dy_m, dz_m [m]."""

    nt: int
    dx_m: float
    nyp: int
    nzp: int
    dy_m: float
    dz_m: float

    @property
    def nk1(self) -> int:
        """Slabs of the real-FFT half spectrum along xi."""
        return self.nt // 2 + 1

    @property
    def nk2_half(self) -> int:
        """Stored k2 rows (k2 = 0 .. nyp//2)."""
        return self.nyp // 2 + 1

    def dk(self) -> tuple[float, float, float]:
        """Wavenumber spacings (dk1, dk2, dk3) [rad/m] of the periodic box."""
        return 2 * np.pi / (self.nt * self.dx_m), 2 * np.pi / (self.nyp * self.dy_m), 2 * np.pi / (self.nzp * self.dz_m)

    def k1(self) -> np.ndarray:
        """Physical k1 [rad/m] of the stored slabs: -i dk1 (time reversal, see the module docstring)."""
        return -np.arange(self.nk1) * self.dk()[0]

    def k2(self) -> np.ndarray:
        """k2 [rad/m] of all nyp rows: j dk2 for j <= nyp//2 (Nyquist stored positive), else (j - nyp) dk2."""
        return k2_wavenumbers(self.nyp, self.dy_m)

    def k3(self) -> np.ndarray:
        """k3 [rad/m] of the nzp columns (numpy fftfreq order)."""
        return k3_wavenumbers(self.nzp, self.dz_m)
