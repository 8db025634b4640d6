"""What a Mann store's model predicts for every estimate, on the lattice of the generator's box.

The generator samples the spectral tensor on the lattice of its periodic (xi = U t, y, z) box, nt x nyp x nzp points
spaced U dt, dy, dz (Guo et al. 2023, Eq. 8, 13, 24), so the expected field has L_j = sum over the (k2, k3) lattice of
Phi_ii(k1_j, k2, k3) dk1 dk2 dk3, k1_j = 2 pi f_j / U: the Mann spectrum *as the grid resolves it* (band-limited at
pi/dy, pi/dz, missing the wavenumbers below the finite box's; Mann 1998). Between planes dx apart the space-time tensor
Theta = exp(-dx/(U tau_e)) Phi (Guo et al. 2023, Eq. 13) is used; the rotor-effective wind speed uses Phi_11 |H_R(k2,
k3)|^2 over the grid's rotor points (Eq. 24). The lattice sums are in ``turbgen.validation.mann_lattice``."""

from __future__ import annotations

import math
from functools import partial

import numpy as np
from scipy.interpolate import CubicSpline

from turbgen import fft
from turbgen.grid import Grid
from turbgen.theory.lattice import line_frequencies
from turbgen.theory.mann_spectra import one_point_spectra, variances
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import MannParams
from turbgen.theory.rotor_effective import rews_spectrum_mann
from turbgen.validation.estimators import COMPONENTS
from turbgen.validation.mann_lattice import MannLattice
from turbgen.validation.pair_sums import RhoAccumulator, box_lags, coherency_matrix, real_box_lags
from turbgen.validation.prediction import N_RHO_NODES, SamplingDesign, Theory, plane_separations
from turbgen.validation.store_run import mann_box_from_attrs, mann_params_from_attrs
from turbgen.validation.variance_law import MAX_MODE_POINTS, N_MODE_LINES, top_modes

N_LINE_NODES = 96  # k1 nodes of the Mann lattice sums when not every line is evaluated
EXACT_LATTICE_POINTS = 4_000_000  # evaluate every line exactly when lines x lattice points is below this


def _interp_lines(k1_nodes, values, k1_lines, positive: bool):
    """Node values -> lines: cubic in log-log for positive spectra, linear in log k1 for ratios."""
    x, xl = np.log(k1_nodes[1:]), np.log(np.maximum(k1_lines[1:], k1_nodes[1]))
    out = np.empty(k1_lines.size, dtype=values.dtype)
    out[0] = values[0]
    if positive:
        out[1:] = np.exp(CubicSpline(x, np.log(values[1:]))(xl))
    elif np.iscomplexobj(values):
        out[1:] = np.interp(xl, x, values[1:].real) + 1j * np.interp(xl, x, values[1:].imag)
    else:
        out[1:] = np.interp(xl, x, values[1:])
    return out


def band_limited_spectra(params: MannParams, grid: Grid, k1: np.ndarray, n_theta: int = 24, n_panels: int = 24):
    """Continuous F_ii(k1) = int Phi_ii dk2 dk3 [m^3 s^-2] over |k2| <= pi/dy, |k3| <= pi/dz, two-sided in k1: the model
    the grid can represent without a finite box's sampling, by polar quadrature."""
    kny, knz = np.pi / grid.dy_m, np.pi / grid.dz_m
    tc = np.arctan2(knz, kny)
    gx, gw = np.polynomial.legendre.leggauss(n_theta)
    sectors = [(-tc, tc, 0), (tc, np.pi - tc, 1), (np.pi - tc, np.pi + tc, 0), (np.pi + tc, 2 * np.pi - tc, 1)]
    th, wth, kmax = [], [], []
    for a, b, kind in sectors:
        t = 0.5 * (a + b) + 0.5 * (b - a) * gx
        th.append(t)
        wth.append(0.5 * (b - a) * gw)
        kmax.append(kny / np.abs(np.cos(t)) if kind == 0 else knz / np.abs(np.sin(t)))
    th, wth, kmax = (np.concatenate(v) for v in (th, wth, kmax))
    rx, rw = np.polynomial.legendre.leggauss(8)
    out = np.empty((3, k1.size))
    for n, kk in enumerate(k1):
        s = np.sqrt(kk * kk + params.length_scale_m**-2)
        lo = np.log(1e-7 * s)
        hi = np.log(kmax)  # (n_th,)
        edges = lo + (hi - lo)[:, None] * np.linspace(0.0, 1.0, n_panels + 1)[None, :]
        a, b = edges[:, :-1], edges[:, 1:]
        t = 0.5 * (a + b)[..., None] + 0.5 * (b - a)[..., None] * rx  # (n_th, panels, 8) in ln kappa
        kap = np.exp(t)
        w = 0.5 * (b - a)[..., None] * rw * kap * kap * wth[:, None, None]  # kappa dkappa dtheta = kappa^2 dln
        k2 = kap * np.cos(th)[:, None, None]
        k3 = kap * np.sin(th)[:, None, None]
        phi = sheared_tensor(np.full(k2.shape, kk), k2, k3, params)
        for i in range(3):
            out[i, n] = np.sum(w * phi[i, i])
    return out


def mann_theory(attrs: dict, design: SamplingDesign) -> Theory:
    """Mann space-time expectations on the lattice of the generator's box (module docstring) for ``design``."""
    grid = design.grid
    params = mann_params_from_attrs(attrs)
    box = mann_box_from_attrs(attrs, grid)
    U = float(attrs["U_m_s"])
    lat = MannLattice(params, grid, box, U)
    line_f = line_frequencies(grid.nt, grid.dt_s)
    k1_lines = 2 * np.pi * line_f / U
    dxs = plane_separations(grid)
    # rotor average transfer |H_R|^2 on the lattice (the grid's rotor points inside the box)
    mask_box = np.zeros((box.nyp, box.nzp))
    mask_box[: grid.ny, : grid.nz] = design.rotor_mask
    h2 = np.abs(fft.oneshot().fft2(mask_box)) ** 2 / design.rotor_mask.sum() ** 2
    lines = _line_sums(lat, design, k1_lines, dxs, h2, U)
    # the continuous model band-limited to the grid (sigma_i metrics), smooth in k1: interpolated log-log
    bl_k1 = np.geomspace(k1_lines[1], k1_lines[-1], N_RHO_NODES)
    band_lim = band_limited_spectra(params, grid, bl_k1)
    log_k1 = np.log(k1_lines[1:])
    auto_model = {c: np.concatenate([[0.0], np.exp(CubicSpline(np.log(bl_k1), np.log(band_lim[i]))(log_k1)) * lat.dk1])
                  for i, c in enumerate(COMPONENTS)}
    node_f = design.node_freqs()
    acc, rho_rews = _node_correlations(lat, design, node_f, dxs, h2, U)
    modes = _variance_modes(lat, grid, dxs, k1_lines[1 : N_MODE_LINES + 1], U, box.nyp * box.nzp)
    var = variances(params)
    return Theory(
        model="mann", nt=grid.nt, line_f=line_f, **lines, node_f=node_f,
        rho_all=acc.all, rho_yz=acc.yz, rho_long=acc.long, rho_rews=rho_rews,
        sigma_model={c: math.sqrt(var[c + c]) for c in COMPONENTS}, band=_band(design, box, U), rho_uw=acc.uw,
        long_components="u", auto_model=auto_model, reference=partial(_mann_reference, params, design, U),
        variance_modes=modes,
    )  # fmt: skip


def _line_sums(lat: MannLattice, design: SamplingDesign, k1_lines: np.ndarray, dxs: dict, h2: np.ndarray,
               U: float) -> dict:  # fmt: skip
    """Theory's per-line lattice sums {auto, yz, long, rews, uw} [m^2 s^-2]: at every record line on small lattices,
    else at N_LINE_NODES k1 nodes, interpolated (auto spectra log-log, the others as ratios to them)."""
    grid, seps = design.grid, design.separations
    if k1_lines.size * lat.box.nyp * lat.box.nzp <= EXACT_LATTICE_POINTS:
        k1_nodes = k1_lines
    else:
        k1_nodes = np.concatenate([[0.0], np.geomspace(k1_lines[1], k1_lines[-1], N_LINE_NODES)])
    phase = {s: np.exp(1j * (lat.k2 * s[0] * grid.dy_m + lat.k3 * s[1] * grid.dz_m)) for s in seps}
    nn = k1_nodes.size
    f_nodes = {c: np.empty(nn) for c in COMPONENTS}
    f13 = np.empty(nn)
    yz_nodes = {c: {s: np.empty(nn, complex) for s in seps} for c in COMPONENTS}
    long_nodes = {dx: np.empty(nn) for dx in dxs}
    rews_nodes = np.empty(nn)
    for n, phi, inv_tau in lat.slabs(k1_nodes):
        for i, c in enumerate(COMPONENTS):
            f_nodes[c][n] = phi[i, i].sum()
            for s in seps:
                yz_nodes[c][s][n] = np.sum(phi[i, i] * phase[s])
        f13[n] = phi[0, 2].sum()
        for dx in dxs:
            long_nodes[dx][n] = np.sum(phi[0, 0] * np.exp(-dx / U * inv_tau))  # Theta_11, Eq. 13
        rews_nodes[n] = np.sum(phi[0, 0] * h2)  # Eq. 24 on the lattice
    if k1_nodes is k1_lines:
        return {"auto": f_nodes, "yz": yz_nodes, "long": long_nodes, "rews": rews_nodes, "uw": f13}
    auto = {c: _interp_lines(k1_nodes, f_nodes[c], k1_lines, True) for c in COMPONENTS}

    def ratio_lines(values, ref):
        return _interp_lines(k1_nodes, values / ref, k1_lines, False)

    return {"auto": auto, "yz": {c: {s: ratio_lines(yz_nodes[c][s], f_nodes[c]) * auto[c] for s in seps}
                                 for c in COMPONENTS},
            "long": {dx: ratio_lines(v, f_nodes["u"]) * auto["u"] for dx, v in long_nodes.items()},
            "rews": ratio_lines(rews_nodes, f_nodes["u"]) * auto["u"],
            "uw": ratio_lines(f13, np.sqrt(f_nodes["u"] * f_nodes["w"])) * np.sqrt(auto["u"] * auto["w"])}


def _node_correlations(lat: MannLattice, design: SamplingDesign, node_f: np.ndarray, dxs: dict, h2: np.ndarray,
                       U: float) -> tuple[RhoAccumulator, np.ndarray]:  # fmt: skip
    """Correlation sums at pairs of frequency nodes: the coherencies over all lags from the 2-D FFT of Theta_ii on
    the lattice (RhoAccumulator), and rho_bar of the rotor-effective wind (nodes x nodes)."""
    grid = design.grid
    acc = RhoAccumulator(design, node_f.size)
    slabs = [(phi[[0, 1, 2, 0], [0, 1, 2, 2]].copy(), inv_tau) for _, phi, inv_tau in lat.slabs(2 * np.pi * node_f / U)]
    phis = np.stack([p for p, _ in slabs])  # (nn, 4, nyp, nzp): Phi_11, Phi_22, Phi_33, Phi_13
    inv_taus = np.stack([t for _, t in slabs])  # (nn, nyp, nzp)
    diag = phis[:, :3].sum(axis=(2, 3))  # (nn, 3)
    r0 = np.sum(phis[:, 0] * h2, axis=(1, 2))
    rho_rews = np.zeros((node_f.size, node_f.size))
    for dx, mult in dxs.items():
        decay = np.exp(-dx / U * inv_taus)

        def lags(i):  # coherency of all nodes at the grid's lags (Theta real: half a transform)
            return real_box_lags(phis[:, i] * decay, grid.ny, grid.nz)

        for i, c in enumerate(COMPONENTS):
            acc.add(c, lags(i) / diag[:, i, None, None], mult, dx == 0)
        acc.add_uw(np.abs(lags(3)) ** 2 / (diag[:, 0] * diag[:, 2])[:, None, None], mult)
        c_r = np.sum(phis[:, 0] * decay * h2, axis=(1, 2)) / r0
        rho_rews += mult * np.outer(c_r, c_r) / grid.nx**2
    return acc, rho_rews


def _band(design: SamplingDesign, box, U: float) -> dict:
    """The design's band [rad/m] with the box's extent and lattice spacing, and a note saying what was summed."""
    grid = design.grid
    return design.band(U) | {
        "box_y_m": box.nyp * grid.dy_m,
        "box_z_m": box.nzp * grid.dz_m,
        "k2_min_rad_m": 2 * np.pi / (box.nyp * grid.dy_m),
        "k3_min_rad_m": 2 * np.pi / (box.nzp * grid.dz_m),
        "note": "Mann tensor summed over the box lattice (cells at the k1 axis integrated): |k2| <= pi/dy, "
                f"|k3| <= pi/dz, spacing 2 pi/box size; box {box.nyp} x {box.nzp} points "
                f"({box.nyp * grid.dy_m:g} m x {box.nzp * grid.dz_m:g} m)",
    }


def _variance_modes(lat: MannLattice, grid: Grid, dxs: dict, k1: np.ndarray, U: float, size: int) -> dict:
    """Component -> (len(k1), K) top eigenvalues of the lines' coherency matrices between all points / N
    (``variance_law``); empty for grids above MAX_MODE_POINTS points."""
    if grid.nx * grid.ny * grid.nz > MAX_MODE_POINTS:
        return {}
    out = {c: [] for c in COMPONENTS}
    for _, phi, inv_tau in lat.slabs(k1):
        decay = {dx: np.exp(-dx / U * inv_tau) for dx in dxs}
        for i, c in enumerate(COMPONENTS):
            lags = {dx: box_lags(fft.oneshot().ifft2(phi[i, i] * d) * size, grid.ny, grid.nz) / phi[i, i].sum()
                    for dx, d in decay.items()}
            out[c].append(top_modes(coherency_matrix(lags, grid)))
    return {c: np.array(v) for c, v in out.items()}


def _mann_reference(params: MannParams, design: SamplingDesign, U: float) -> dict:
    """Continuous-model curves (infinite box, no grid cut-off) for the plots: one-sided S(f) = 2 F(k1) 2 pi / U."""
    setup, grid, mask = design.setup, design.grid, design.rotor_mask
    f = np.geomspace(setup.freqs[1], setup.freqs[-1], 64)
    k1 = 2 * np.pi * f / U
    spec = one_point_spectra(k1, params)
    conv = 2.0 * 2 * np.pi / U
    out = {f"spectrum_{c}": (f, conv * spec[name]) for c, name in zip(COMPONENTS, ("F11", "F22", "F33"))}
    out["uw_cross_spectrum"] = (f, conv * spec["F13"])
    # Eq. 24 for the continuous disc of the rotor radius (the expectation uses the grid's rotor points)
    radius = float(np.sqrt(mask.sum() * grid.dy_m * grid.dz_m / np.pi))
    out["rews_spectrum"] = (f[::2], conv * rews_spectrum_mann(k1[::2], params, radius))
    return out
