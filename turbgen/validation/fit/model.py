"""The Mann model's expected band spectra of fit data: continuous (sensor data) or on the store's lattice.

Continuous model: F_ij(k1; ae, L, Gamma) = ae L^(5/3) f_ij(k1 L, Gamma), f_ij interpolated from a table (``table``).
A store's grid model multiplies it by the ratio of the lattice sum of the tensor over the generator's box
(``turbgen.validation.mann_lattice``) to the continuous spectrum, at N_RATIO_NODES k1 nodes (``MannFit`` updates it as
the fit moves). A sonic's path (``paths_m``) multiplies the lines of F_ij by T_ij(k1 p) (``turbgen.theory.sonic_path``),
averaged over the columns. Every bin's expected Welch estimate is that of a periodic line process with these spectra
(``welch_kernel.WelchKernel``: leakage and segment-mean removal), averaged over the bands.

``coherency``: the cross-spectra between points (``covariance``); on the lattice a 2-D transform of the tensor over
(k2, k3) times the decay between planes (Guo et al. 2023, Eq. 13); continuous, Eq. 8 at each separation, frozen (the
decay between sensors along x is not known; ignoring it errs towards wider intervals)."""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import numpy as np

from turbgen import fft
from turbgen.theory import ranges
from turbgen.theory.lattice import line_frequencies
from turbgen.theory.mann_quadrature import perpendicular_quadrature
from turbgen.theory.params import MannParams
from turbgen.theory.sonic_path import path_transfer
from turbgen.validation.fit.spectra import BandSpectra
from turbgen.validation.fit.table import NAMES, scaled_spectra
from turbgen.validation.mann_lattice import MannLattice
from turbgen.validation.welch_kernel import WelchKernel

N_RATIO_NODES = 96
RATIO_STEP = 1e-3  # step in ln L and Gamma of the ratio's derivatives (``update_ratio``)
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
# Eq. 8 between sensors for the weights only: 4 Gauss nodes and 64 angles leave ~2e-4 of F_ii, far cheaper
WEIGHT_RULE = {"n_gauss": 4, "n_theta": 64}
REUSE_LN_L, REUSE_GAMMA = 0.05, 0.1  # cross-spectra between points are reused while L and Gamma stay this close
LINE_NODES = 24  # k1 nodes of the continuous cross-spectra between sensors for ``line_cross`` (smooth in ln k1)
# beyond s d = 20 (s = sqrt(k1^2 + L^-2), d the y-z separation) the coherency between points is < 1e-6 (7e-7 at most
# over Gamma 0-5, L 10-100 m, d along y or z, by the quadrature with a 64 x longer radial cut): taken as 0 there, where
# WEIGHT_RULE's own error is 2.6e-5 and its oscillating integrand made a 20 Hz mast's weights slow
SD_NEGLIGIBLE = 20.0
_kernel = lru_cache(maxsize=4)(WelchKernel)  # a Welch setup's kernel (parameter-free): built once per setup


class BandModel:
    """Expected band spectra of ``bands`` (BandSpectra) for Mann parameters (module docstring), k1 = 2 pi f / ``U_m_s``
    [m/s]: with the store's ``grid`` and periodic ``box`` the grid model, else the continuous one, from the table of
    the eddy ``lifetime`` (``MannParams.lifetime``), ``paths_m`` as ``FitData.spectrum_paths``."""

    def __init__(self, bands: BandSpectra, U_m_s: float, grid=None, box=None, lifetime: str = "guo", paths_m=None):
        self.bands, self.U, self.grid, self.box, self.lifetime = bands, U_m_s, grid, box, lifetime
        self.kind = "continuous" if grid is None else "grid"
        nt, dt = bands.nt, bands.setup.dt_s
        self.k1 = 2 * np.pi * line_frequencies(nt, dt)[1:] / U_m_s  # lines 1 .. nt/2 [rad/m]
        self.transfer = {n: np.mean([path_transfer(self.k1 * p)[n] for p in ps], axis=0)
                         for n, ps in (paths_m or {}).items()}  # fmt: skip
        self.dk1 = 2 * np.pi / (nt * dt * U_m_s)
        self.kernel = k = _kernel(bands.setup, nt)
        self.gain = np.zeros((len(bands.bands), nt // 2 + 1))  # ``expected`` = gain @ line variances: the kernel's
        for g, b in zip(self.gain, bands.bands):  # rows averaged over each band (nbands x lines, not bins x lines)
            np.add.at(g, k.idx[b], k.k[b])
        self.gain /= [[b.size] for b in bands.bands]
        self.ratio_k1 = np.geomspace(self.k1[0], self.k1[-1], N_RATIO_NODES)
        self.ratio: dict | None = None  # name -> (N_RATIO_NODES,) lattice / continuous, set by ``update_ratio``
        self.ratio_at, self.ratio_slope = None, None  # (ln L, Gamma) of ``ratio``, its derivatives there
        self._cross: tuple | None = None  # (params, separations, cross-spectra) of the last ``coherency``

    def update_ratio(self, params: MannParams, slopes: bool = False) -> None:
        """Lattice sum / continuous spectrum at the ratio nodes for ``params`` (grid model only); with ``slopes``
        also its derivatives in ln L and Gamma (forward differences of RATIO_STEP), so that ``line_spectra`` moves
        the ratio with L and Gamma to first order: the fit's Jacobian then holds the ratio's dependence on them."""
        if self.grid is None:
            return
        self.ratio, self.ratio_at = self._ratio(params), (math.log(params.length_scale_m), params.gamma)
        self.ratio_slope = None
        if slopes:
            hl = RATIO_STEP if params.length_scale_m * math.exp(RATIO_STEP) <= ranges.RANGES["length_scale_m"].hi \
                else -RATIO_STEP
            hg = RATIO_STEP if params.gamma + RATIO_STEP <= ranges.RANGES["gamma"].hi else -RATIO_STEP
            moved = (self._ratio(replace(params, length_scale_m=params.length_scale_m * math.exp(hl))),
                     self._ratio(replace(params, gamma=params.gamma + hg)))
            self.ratio_slope = tuple({n: (r[n] - self.ratio[n]) / h for n in NAMES} for r, h in zip(moved, (hl, hg)))

    def _ratio(self, params: MannParams) -> dict:
        lat = MannLattice(params, self.grid, self.box, self.U)
        sums = {n: np.empty(N_RATIO_NODES) for n in NAMES}
        for k, phi, _ in lat.slabs(self.ratio_k1):
            for n, (i, j) in zip(NAMES, ((0, 0), (1, 1), (2, 2), (0, 2))):
                sums[n][k] = phi[i, j].sum() / self.dk1
        cont = scaled_spectra(self.ratio_k1 * params.length_scale_m, params.gamma, self.lifetime)
        scale = params.ae * params.length_scale_m ** (5.0 / 3.0)
        return {n: sums[n] / (scale * cont[n]) for n in NAMES}

    def line_spectra(self, ae: float, length_scale_m: float, gamma: float) -> dict:
        """Name -> (nt/2,) two-sided F(k1) [m^3 s^-2] at the record's lines 1 .. nt/2 (times the grid ratio)."""
        f, scale = scaled_spectra(self.k1 * length_scale_m, gamma, self.lifetime), ae * length_scale_m ** (5.0 / 3.0)
        ratio = {n: 1.0 if self.ratio is None else np.interp(np.log(self.k1), np.log(self.ratio_k1), self._ratio_of(
            n, length_scale_m, gamma)) for n in NAMES}
        return {n: scale * f[n] * ratio[n] * self.transfer.get(n, 1.0) for n in NAMES}

    def _ratio_of(self, n: str, length_scale_m: float, gamma: float) -> np.ndarray:
        """The ratio of spectrum ``n`` at the nodes for L and Gamma (to first order about ``ratio_at``)."""
        if self.ratio_slope is None:
            return self.ratio[n]
        dl, dg = math.log(length_scale_m) - self.ratio_at[0], gamma - self.ratio_at[1]
        return self.ratio[n] + dl * self.ratio_slope[0][n] + dg * self.ratio_slope[1][n]

    def expected(self, ae: float, length_scale_m: float, gamma: float) -> dict:
        """Name ("uu", "vv", "ww", "uw") -> (nbands,) expected band-averaged Welch estimate [m^2 s^-2 Hz^-1]."""
        spec = self.line_spectra(ae, length_scale_m, gamma)  # line variances F(k1_j) dk1 at j = 1 .. nt/2
        return dict(zip(spec, np.stack(list(spec.values())) @ self.gain[:, 1:].T * self.dk1))

    def coherency(self, params: MannParams, seps_m: np.ndarray) -> np.ndarray:
        """(nbands, 3, 3, D) complex coherency S_pq(d) / sqrt(S_pp(0) S_qq(0)) at each band's centre and the
        separations ``seps_m`` (D, 3) [m] of x, y, z (module docstring; the tensor is real and symmetric, so
        S_qp(d) = S_pq(d) and S_pq(-d) = conj S_pq(d))."""
        k1 = 2 * np.pi * self.bands.f_hz / self.U
        c = self._cross  # the cross-spectra only weight the fit: reused while the parameters stay close
        if c is None or c[1] is not seps_m or abs(math.log(params.length_scale_m / c[0].length_scale_m)) > \
                REUSE_LN_L or abs(params.gamma - c[0].gamma) > REUSE_GAMMA:
            cross = self._continuous_cross if self.grid is None else self._lattice_cross
            self._cross = c = (params, seps_m, cross(params, seps_m, k1))
        s, zero = c[2], np.flatnonzero(np.all(seps_m == 0, axis=1))[0]
        diag = np.sqrt(np.abs(s[:, [0, 1, 2], [0, 1, 2], zero]))
        return s / (diag[:, :, None, None] * diag[:, None, :, None])

    def line_cross(self, params: MannParams, seps_m: np.ndarray, nlines: int) -> np.ndarray:
        """(nlines, 3, 3, D) cross-variances E Y_q^a conj Y_q^b [m^2 s^-2] of the record's lines q = 1 .. ``nlines``
        between points ``seps_m`` (D, 3) [m] apart: the lattice sum, or continuous F(k1_q) dk1 (Eq. 8 of Guo et
        al. 2023: a sensor record taken as periodic)."""
        if self.grid is not None:
            return self._lattice_cross(params, seps_m, self.k1[:nlines])
        f = self.line_spectra(params.ae, params.length_scale_m, params.gamma)  # the table at zero separation
        one = np.zeros((self.k1.size, 3, 3))
        for n, (p, q) in zip(NAMES, ((0, 0), (1, 1), (2, 2), (0, 2))):
            one[:, p, q] = one[:, q, p] = f[n]
        zero = np.all(seps_m == 0, axis=1)
        out = np.zeros((nlines, 3, 3, seps_m.shape[0]), complex)
        out[..., zero] = one[:nlines, :, :, None]
        if not zero.all():  # coherencies at LINE_NODES of the lines, linear in ln k1 between them, times the table's
            nodes = np.unique(np.geomspace(1, nlines, LINE_NODES).astype(int)) - 1
            x, xi = np.log(self.k1[nodes]), np.log(self.k1[:nlines])
            auto = np.sqrt(np.abs(np.diagonal(one, axis1=1, axis2=2)))  # (nt/2, 3)
            g = self._continuous_cross(params, seps_m[~zero], self.k1[nodes]) / _outer(auto[nodes])
            j = np.clip(np.searchsorted(x, xi, side="right") - 1, 0, x.size - 2)
            t = ((xi - x[j]) / (x[j + 1] - x[j]))[:, None, None, None]
            out[..., ~zero] = ((1 - t) * g[j] + t * g[j + 1]) * _outer(auto[:nlines])
        return out * self.dk1

    def _lattice_cross(self, params, seps_m, k1) -> np.ndarray:
        g = self.grid
        lat = MannLattice(params, g, self.box, self.U)
        ly = np.rint(seps_m[:, 1] / g.dy_m).astype(int) % self.box.nyp
        lz = np.rint(seps_m[:, 2] / g.dz_m).astype(int) % self.box.nzp
        dxs, which = np.unique(np.abs(seps_m[:, 0]), return_inverse=True)
        out = np.zeros((k1.size, 3, 3, seps_m.shape[0]), complex)
        for b, phi, inv_tau in lat.slabs(k1):
            for m, dx in enumerate(dxs):
                sel = which == m
                decayed = phi[[p for p, _ in PAIRS], [q for _, q in PAIRS]]
                if dx > 0:  # frozen: 1 / tau = 0; at k = 0 it may be inf
                    decayed = decayed * np.exp(-dx / self.U * inv_tau)
                lags = fft.oneshot().ifft2(decayed) * decayed[0].size  # sum Phi exp(i k.d) at lags d
                for n, (p, q) in enumerate(PAIRS):
                    out[b, p, q, sel] = out[b, q, p, sel] = lags[n][ly[sel], lz[sel]]
        return out

    def _continuous_cross(self, params, seps_m, k1) -> np.ndarray:
        out = np.zeros((k1.size, 3, 3, seps_m.shape[0]), complex)
        done: dict = {}
        for d, (_, y, z) in enumerate(np.round(seps_m, 6) + 0.0):
            if (y, z) not in done:
                if (-y + 0.0, -z + 0.0) in done:
                    done[(y, z)] = np.conj(done[(-y + 0.0, -z + 0.0)])
                else:
                    near = np.hypot(k1, 1 / params.length_scale_m) * math.hypot(y, z) <= SD_NEGLIGIBLE
                    s = np.zeros((k1.size, 3, 3), complex)
                    if near.any():
                        _, w, gq = perpendicular_quadrature(k1[near], params, PAIRS, float(y), float(z),
                                                            _rule=WEIGHT_RULE)
                        for p, q in PAIRS:
                            s[near, p, q] = s[near, q, p] = (w * gq[(p, q)]).sum(axis=-1)
                    done[(y, z)] = s
            out[..., d] = done[(y, z)]
        return out


def _outer(a: np.ndarray) -> np.ndarray:
    """(n, 3, 3, 1) a_p a_q of (n, 3) a."""
    return (a[:, :, None] * a[:, None, :])[..., None]
