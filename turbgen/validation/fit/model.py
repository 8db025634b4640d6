"""The Mann model's expected band spectra of fit data: continuous (sensor data) or on the store's lattice.

Continuous model: F_ij(k1; ae, L, Gamma) = ae L^(5/3) f_ij(k1 L, Gamma), f_ij interpolated from a table
(``turbgen.validation.fit.table``). A store's grid model multiplies it by the ratio of the lattice sum
of the tensor over the generator's box (``turbgen.validation.mann_lattice``, the validator's "theo. (grid)") to the
continuous spectrum, at N_RATIO_NODES k1 nodes for given parameters (``MannFit`` updates it as the fit moves).

The expected Welch estimate of every bin is that of a periodic line process with these spectra
(``welch_kernel.WelchKernel``: leakage and segment-mean removal in the lowest bins), averaged over the bands.
"""

from __future__ import annotations

import numpy as np

from turbgen.theory.lattice import line_frequencies
from turbgen.theory.params import MannParams
from turbgen.validation.fit.spectra import BandSpectra
from turbgen.validation.fit.table import NAMES, scaled_spectra
from turbgen.validation.mann_lattice import MannLattice
from turbgen.validation.welch_kernel import WelchKernel

N_RATIO_NODES = 96


class BandModel:
    """Expected band spectra of ``bands`` for Mann parameters (module docstring).

    Parameters
    ----------
    bands : BandSpectra
        The estimates (Welch setup, record length, bands).
    U_m_s : float
        Mean wind speed [m/s] (k1 = 2 pi f / U).
    grid, box : optional
        The store's grid and periodic box: the grid model; None: the continuous model.
    """

    def __init__(self, bands: BandSpectra, U_m_s: float, grid=None, box=None):
        self.bands, self.U, self.grid, self.box = bands, U_m_s, grid, box
        nt, dt = bands.nt, bands.setup.dt_s
        self.k1 = 2 * np.pi * line_frequencies(nt, dt)[1:] / U_m_s  # lines 1 .. nt/2 [rad/m]
        self.dk1 = 2 * np.pi / (nt * dt * U_m_s)
        self.kernel = WelchKernel(bands.setup, nt)
        self.ratio_k1 = np.geomspace(self.k1[0], self.k1[-1], N_RATIO_NODES)
        self.ratio = None  # name -> (N_RATIO_NODES,) lattice / continuous, set by ``update_ratio``

    @property
    def kind(self) -> str:
        return "continuous" if self.grid is None else "grid"

    def update_ratio(self, params: MannParams) -> None:
        """Lattice sum / continuous spectrum at the ratio nodes for ``params`` (grid model only)."""
        if self.grid is None:
            return
        lat = MannLattice(params, self.grid, self.box, self.U)
        sums = {n: np.empty(N_RATIO_NODES) for n in NAMES}
        for k, phi, _ in lat.slabs(self.ratio_k1):
            for n, (i, j) in zip(NAMES, ((0, 0), (1, 1), (2, 2), (0, 2))):
                sums[n][k] = phi[i, j].sum() / self.dk1
        cont = scaled_spectra(self.ratio_k1 * params.length_scale_m, params.gamma)
        scale = params.ae * params.length_scale_m ** (5.0 / 3.0)
        self.ratio = {n: sums[n] / (scale * cont[n]) for n in NAMES}

    def line_spectra(self, ae: float, length_scale_m: float, gamma: float) -> dict:
        """Name -> (nt/2,) two-sided F(k1) [m^3 s^-2] at the record's lines 1 .. nt/2 (times the grid ratio)."""
        f = scaled_spectra(self.k1 * length_scale_m, gamma)
        scale = ae * length_scale_m ** (5.0 / 3.0)
        out = {}
        for n in NAMES:
            r = 1.0 if self.ratio is None else np.interp(np.log(self.k1), np.log(self.ratio_k1), self.ratio[n])
            out[n] = scale * f[n] * r
        return out

    def expected(self, ae: float, length_scale_m: float, gamma: float) -> dict:
        """Name ("uu", "vv", "ww", "uw") -> (nbands,) expected band-averaged Welch estimate [m^2 s^-2 Hz^-1]."""
        out = {}
        for n, spec in self.line_spectra(ae, length_scale_m, gamma).items():
            lines = np.concatenate([[0.0], spec * self.dk1])  # line variances L_j = F(k1_j) dk1, j = 0 .. nt/2
            out[n] = self.bands.band_mean(self.kernel.apply(lines))
        return out
