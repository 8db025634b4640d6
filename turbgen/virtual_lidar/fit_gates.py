"""The eddy-evolution time from the range gates of an inclined beam (Guo et al. 2022), for ``turbgen fit mann LIDAR``.

Two gates a, b of one beam are read at the same scan times; their v_los series, shifted by whole scans of Taylor's
delay (``evolution._aligned``), have the line cross-variances C_ab(k1) = sum_k n . Phi(k) n A_a conj(A_b)
exp(-|x_b - x_a| / (U tau_e(k))) exp(-i k1 U L dt) over the sampled store's (k2, k3) lattice (Guo et al. 2023, Eq. 8,
13, 29), A the gates' complex amplitudes as the sampler reads them (``fit.sampled_amplitudes``: probe volume,
interpolation, and the phase of each gate's position, across the wind too), L dt the shift. Unlike two gates on a beam
along x they differ in y and z, so even the frozen field (gamma -> inf) is not fully coherent: gamma is what the
co-coherence loses beyond that. The co-coherence is fitted by ``evolution.fit_pairs`` (the same estimator, covariance
and interval as for masts); the beam's own lattice model (N_NODES k1 nodes, interpolated) replaces theirs."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.interpolate import CubicSpline

from turbgen.theory.eddy_lifetime import evolution_lifetime_s
from turbgen.theory.lattice import line_frequencies
from turbgen.theory.lidar_lattice import lattice_tensor, lattice_wavenumbers
from turbgen.theory.lidar_preview import KAPPA_MAX, N_THETA, PANEL_WIDTH, polar_nodes, weight_tables
from turbgen.theory.lidar_weighting import discrete_transform
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import MannParams
from turbgen.validation.fit.data import FitData
from turbgen.validation.fit.evolution import N_NODES, fit_pairs, taylor_rest
from turbgen.validation.fit.result import MannFit
from turbgen.validation.welch_kernel import WelchKernel
from turbgen.virtual_lidar.fit import GAIN_MIN, TAIL, SampledStore, sampled_amplitudes

MAX_GATES = 4  # gates of the beam fitted (6 pairs: the continuous plane holds ~10^5 nodes per k1 node and pair)


class GateCoherence:
    """Expected band co-coherence of two gates of one beam as a function of gamma (module docstring), ae, L, Gamma
    held: the model ``evolution.fit_pairs`` takes. ``meas``: the beam's gates (Measurements, rows in the order of
    ``positions``, their (x, y, z) foci [m]); ``store``: the sampled store (its lattice, the sampler's amplitudes) or
    None (the continuous (k2, k3) plane of the preview theory, A = phi_hat(k . n) times the focus' phase);
    ``amplitudes``: the gates' amplitudes at the k1 nodes if known."""

    def __init__(self, bands, data: FitData, params: MannParams, meas, positions: tuple, store: SampledStore | None,
                 amplitudes: dict | None = None):  # fmt: skip
        self.bands, self.data, self.params, self.meas, self.store = bands, data, params, meas, store
        nt, dt, U = bands.nt, bands.setup.dt_s, data.U_m_s
        self.U, self.kernel = U, WelchKernel(bands.setup, nt)
        self.k1 = 2 * np.pi * line_frequencies(nt, dt)[1:] / U
        self.nodes = np.geomspace(self.k1[0], self.k1[-1], N_NODES)
        if store is None:  # the LOS spectra's quadrature (fit._quadrature): out to TAIL x the highest k1 passed
            gain = discrete_transform(self.nodes * meas.n[0, 0], meas.offsets_m[0], meas.weights[0]) ** 2
            top = TAIL * float(self.nodes[gain >= GAIN_MIN].max(initial=self.nodes[0]))
            self.k2, self.k3, self.dk = polar_nodes(max(KAPPA_MAX, top), N_THETA, PANEL_WIDTH)
        else:
            self.k2, self.k3 = lattice_wavenumbers(store.box)
        self.amplitudes = amplitudes or {p: self._amplitude(meas.subset([i])) for i, p in enumerate(positions)}
        n = meas.n[0]
        self.weight = np.stack([np.einsum("i,ijk,j->k", n, self._tensor(float(k)), n) for k in self.nodes])
        k = np.sqrt(self.nodes[:, None] ** 2 + self.k2[None] ** 2 + self.k3[None] ** 2)
        self.rate = 1.0 / evolution_lifetime_s(k, replace(params, evo_time_s=1.0))  # 1 / tau_e at gamma = 1 s
        self.positions, self._cross, self._autos = positions, {}, {}

    def _tensor(self, k1: float) -> np.ndarray:
        """(3, 3, nodes) Phi dk2 dk3 [m^3 s^-2] at ``k1`` on the (k2, k3) nodes."""
        if self.store is not None:
            return lattice_tensor(self.store.box, k1, self.params, self.U)
        return sheared_tensor(k1, self.k2, self.k3, self.params) * self.dk

    def _amplitude(self, m) -> np.ndarray:
        """(phases, k1 nodes, (k2, k3) nodes) complex amplitude of the gate ``m`` (Measurements of one row)."""
        if self.store is not None:
            return sampled_amplitudes(self.nodes, m, self.U, self.store)
        (n1, n2, n3), (x, y, z) = m.n[0], m.focus_m[0]
        nu, (table, *_), _ = weight_tables(m, self.nodes[-1] + np.hypot(self.k2, self.k3).max())  # |k . n| <= |k|
        return np.stack([[(np.interp(np.abs(k * n1 + self.k2 * n2 + self.k3 * n3), nu, table)
                           * np.exp(1j * (-k * x + self.k2 * y + self.k3 * z))).astype(np.complex64)
                          for k in self.nodes]])  # fmt: skip

    def moved(self, params: MannParams) -> GateCoherence:
        """The same gates for other ae, L, Gamma (their amplitudes kept)."""
        return GateCoherence(self.bands, self.data, params, self.meas, self.positions, self.store, self.amplitudes)

    @staticmethod
    def along_wind(a: tuple, b: tuple) -> bool:
        return False  # gates of an inclined beam differ across the wind: the frozen field's co-coherence is < 1

    def _mass(self, a: tuple, b: tuple) -> np.ndarray:
        """(nodes, lattice) n . Phi n A_a conj(A_b) averaged over the scan phases, the Taylor phase exp(i k1 (x_b -
        x_a)) of A_a conj(A_b) removed (smooth in k1); single precision (the continuous plane's ~10^5 nodes)."""
        if (a, b) not in self._cross:
            amp = self.amplitudes
            cross = np.mean(amp[a] * np.conj(amp[b]), axis=0) * self.weight
            self._cross[a, b] = (cross * np.exp(-1j * self.nodes * (b[0] - a[0]))[:, None]).astype(np.complex64)
        return self._cross[a, b]

    def _auto(self, p: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(LOS spectrum at the nodes, at the record's lines (cubic in log-log), its expected Welch bands) of the
        gate at ``p``."""
        if p not in self._autos:
            f = self._mass(p, p).real.sum(1)
            lines = np.exp(CubicSpline(np.log(self.nodes), np.log(f))(np.log(self.k1)))
            self._autos[p] = f, lines, self._welch(lines).real
        return self._autos[p]

    def _welch(self, lines: np.ndarray) -> np.ndarray:
        return self.bands.band_mean(self.kernel.apply(np.concatenate([[0.0], lines])))

    def expected(self, gamma_s: float, a: tuple, b: tuple) -> np.ndarray:
        """(nbands,) expected co-coherence of the gates at ``a``, ``b`` (x, y, z) [m] after their shifts (before the
        estimator's bias); gamma_s = inf: the frozen field's."""
        (f_a, line_a, welch_a), (f_b, line_b, welch_b) = self._auto(a), self._auto(b)
        decay = np.exp(-self.rate * (abs(b[0] - a[0]) / (self.U * gamma_s)))
        rho = (self._mass(a, b) * decay).sum(1) / np.sqrt(f_a * f_b)
        ln_k1, ln_nodes = np.log(self.k1), np.log(self.nodes)
        rho_lines = np.interp(ln_k1, ln_nodes, rho.real) + 1j * np.interp(ln_k1, ln_nodes, rho.imag)
        turn = np.exp(1j * self.k1 * self.U * taylor_rest(self.data, a[0], b[0]))  # the rest of the delay, e^(i w d)
        return self._welch(rho_lines * np.sqrt(line_a * line_b) * turn).real / np.sqrt(welch_a * welch_b)


def gate_rows(meas) -> np.ndarray | None:
    """Rows of ``meas`` whose gates are fitted, by range: the first beam with gates at two or more ranges, at most
    MAX_GATES of them (the nearest, the farthest and evenly between); None without such a beam."""
    beams = [b for b in np.unique(meas.beam) if np.unique(np.round(meas.focus_m[meas.beam == b, 0], 6)).size > 1]
    if not beams:
        return None
    rows = np.flatnonzero(meas.beam == beams[0])
    rows = rows[np.argsort(meas.focus_m[rows, 0], kind="stable")]
    if rows.size > MAX_GATES:
        rows = rows[[k * (rows.size - 1) // (MAX_GATES - 1) for k in range(MAX_GATES)]]
    return rows


def with_inclined_gates(fd: FitData, meas, fit: MannFit, store: SampledStore | None) -> MannFit:
    """``fit`` with the evolution time from the gates of the first beam that has two or more ranges, or a note saying
    why there is none. One beam only: the gates of different beams covary too (their cross-beam coherence is not
    modelled), so pooling them would understate the interval."""
    rows = gate_rows(meas)
    if rows is None:
        return replace(fit, notes=fit.notes + ("evo_time_s not fitted: no beam has gates at two or more ranges",))
    positions = tuple(tuple(float(c) for c in meas.focus_m[i]) for i in rows)
    data = replace(fd, series={"u": fd.series["u"][:, rows]}, columns={"u": np.arange(rows.size)},
                   sites_m=meas.focus_m[rows], u_xyz_m=positions)
    pairs = {(positions[i], positions[j]): [(i, j)] for i in range(rows.size) for j in range(i + 1, rows.size)
             if positions[j][0] - positions[i][0] > 1e-6}

    def model_of(bands) -> GateCoherence:
        return GateCoherence(bands, data, fit.params, meas.subset(rows), positions, store)

    evo = fit_pairs(data, pairs, model_of, fit.nperseg, fit)
    one = (f"evo_time_s from the gates of beam {int(meas.beam[rows[0]])} only (the beams' cross-coherence is not modelled), at "
           f"x = {', '.join(f'{p[0]:.4g}' for p in positions)} m")
    return replace(fit, evolution=evo, notes=fit.notes + (evo.message, one))
