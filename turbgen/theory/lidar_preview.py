"""Lidar preview quality: REWS spectra, lidar-rotor coherence and Wiener gain (Guo et al. 2023, Sect. 3).

u_RR is the mean u over the rotor disc of radius R at x = 0 (Eq. 23); u_LL = (1/M) sum_i v_los,i / n_i1
over one scan's M measurements (Eq. 28 without its stray outer factor; Fu et al. 2023, Eq. 23), each shifted
by its preview time x_i / U, so only the eddies' evolution over |x_i - x_j| / U remains (Eq. 29, 32).

Mann (space-time tensor, two-sided in k1), with A_g(k) = sum_{i in gate g} n_i phi_hat_i(k . n_i)
exp(i (k2 y_i + k3 z_i)) / (M n_i1), r = 2 J1(kappa R) / (kappa R) and D = exp(-dt / tau_e(|k|)):
  S_LL = ∫ sum_{g,h} D(k, |x_g - x_h|/U) A_g^T Phi A_h^* dk_perp   (Eq. 29)
  S_RL = ∫ sum_g D(k, x_g/U) r sum_m Phi_1m A_g,m^* dk_perp         (Eq. 32)
  S_RR = ∫ r^2 Phi_11 dk_perp                                       (Eq. 24)
The (k2, k3) integral is one polar quadrature for all three (so errors cancel in the coherence), or with
``box`` the lattice of a periodic synthesis box. A single *point* needs a larger ``kappa_max``.

Kaimal (direct product, Eq. 25, 31, 33): S_c(f) coh_yz(r, f) gamma_x(dx, f) between the probe-volume
samples, the rotor on a square grid. gamma^2_RL (Eq. 34), |G_RL| (Eq. 35)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import j1

from turbgen.errors import ParameterError, check_positive
from turbgen.theory.coherence_models import exponential_yz
from turbgen.theory.eddy_lifetime import evolution_lifetime_s
from turbgen.theory.kaimal import kaimal_spectrum
from turbgen.theory.lattice import gauss_panel
from turbgen.theory.lidar_geometry import Measurements
from turbgen.theory.lidar_lattice import BoxLattice, lattice_tensor, lattice_wavenumbers
from turbgen.theory.lidar_preview_kernel import node_sums
from turbgen.theory.lidar_weighting import discrete_transform
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import KaimalParams, MannParams, check_wind_speed
from turbgen.theory.rotor_effective import rews_spectrum_kaimal

KAPPA_LO = 1e-5  # rad/m, lowest radial node
KAPPA_SPLIT = 0.02  # rad/m: log panels below, uniform panels above
KAPPA_MAX = 1.0  # rad/m
PANEL_WIDTH = 0.05  # rad/m, resolves exp(i kappa r) for point separations up to ~150 m
N_GAUSS = 8
N_THETA = 160


@dataclass(frozen=True)
class PreviewSpectra:
    """One-sided spectra of u_RR, u_LL and their complex cross-spectrum [m^2 s^-2 Hz^-1] at ``f_hz`` [Hz]."""

    f_hz: np.ndarray
    S_RR: np.ndarray
    S_LL: np.ndarray
    S_RL: np.ndarray

    @property
    def coh2_RL(self) -> np.ndarray:
        """Magnitude-squared lidar-rotor coherence |S_RL|^2 / (S_RR S_LL) [-] (Guo et al. 2023, Eq. 34)."""
        return np.abs(self.S_RL) ** 2 / (self.S_RR * self.S_LL)

    @property
    def G_RL(self) -> np.ndarray:
        """Wiener gain |G_RL| = |S_RL| / S_LL [-] (Guo et al. 2023, Eq. 35)."""
        return np.abs(self.S_RL) / self.S_LL


def _check(f_hz, meas: Measurements, U_m_s: float, radius_m: float):
    f = np.atleast_1d(np.asarray(f_hz, dtype=float))
    if f.size == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise ParameterError("f (Hz) must be positive finite numbers")
    U = check_wind_speed(U_m_s)
    R = check_positive("rotor radius (m)", radius_m)
    if meas.count == 0:
        raise ParameterError("the lidar has no measurements")
    if np.any(meas.n[:, 0] <= 1e-6):
        raise ParameterError("every beam must look upstream (n_1 > 0): u_LL divides by n_1")
    return f, U, R


def _radial_nodes(kappa_max: float = KAPPA_MAX, panel: float = PANEL_WIDTH):
    edges = np.append(np.exp(np.arange(np.log(KAPPA_LO), np.log(KAPPA_SPLIT), 1.0)), KAPPA_SPLIT)
    edges = np.concatenate([edges, np.arange(KAPPA_SPLIT + panel, kappa_max + 0.5 * panel, panel)])
    parts = [gauss_panel(a, b, N_GAUSS) for a, b in zip(edges[:-1], edges[1:])]
    kappa = np.concatenate([x for x, _ in parts])
    return kappa, np.concatenate([w for _, w in parts]) * kappa  # kappa dkappa


def weight_tables(meas: Measurements, nu_max: float):
    """(|nu| grid [rad/m] of step ~2e-4 up to ``nu_max``, phi_hat on it for each distinct probe volume, each row's
    table): rows sharing offsets and weights share a table; read linearly between the grid's points."""
    keys, first, inverse = np.unique(np.hstack([meas.offsets_m, meas.weights]).round(12), axis=0,
                                     return_index=True, return_inverse=True)
    nu = np.linspace(0.0, nu_max, int(nu_max / 2e-4) + 2)
    tables = [discrete_transform(nu, meas.offsets_m[i], meas.weights[i]) for i in first]
    return nu, tables, inverse.ravel()


def polar_nodes(kappa_max: float, n_theta: int, panel_width: float):
    """Flat (k2, k3) [rad/m] nodes of the polar quadrature and their weights kappa dkappa dtheta."""
    kappa, wk = _radial_nodes(kappa_max, panel_width)
    theta = 2.0 * np.pi * np.arange(n_theta) / n_theta
    k2 = (kappa[:, None] * np.cos(theta)[None, :]).ravel()
    k3 = (kappa[:, None] * np.sin(theta)[None, :]).ravel()
    return k2, k3, np.repeat(wk * (2.0 * np.pi / n_theta), n_theta)


class _Lidar:
    """What the spectra need of the measurements at any node set: gates, beams, probe-volume tables, phases."""

    def __init__(self, meas: Measurements, k2: np.ndarray, k3: np.ndarray, nu_max: float):
        x_gate = meas.focus_m[:, 0]
        self.xs, gate_of = np.unique(np.round(x_gate, 6), return_inverse=True)
        self.gate_of = gate_of.ravel().astype(np.int64)
        nu, tables, table_of = weight_tables(meas, nu_max)
        self.nu_step, self.tables = float(nu[1] - nu[0]), np.array(tables, dtype=float)
        # measurements that share a LOS vector and a probe volume share phi_hat(k . n) (a beam's gates)
        beams, beam_of = np.unique(np.hstack([meas.n.round(12), table_of[:, None]]), axis=0, return_inverse=True)
        self.beams, self.beam_table = np.ascontiguousarray(beams[:, :3]), beams[:, 3].astype(np.int64)
        self.beam_of = beam_of.ravel().astype(np.int64)
        self.scale = meas.n / (meas.count * meas.n[:, :1])  # n_i / (M n_i1)
        # exp(i (k2 y_i + k3 z_i)) does not depend on k1: once per measurement (complex64 halves the memory)
        self.phase = np.exp(1j * (k2[None] * meas.focus_m[:, 1, None] + k3[None] * meas.focus_m[:, 2, None]))
        self.phase = self.phase.astype(np.complex64)


def _node_spectra(lidar: _Lidar, k1: float, k2, k3, phi_w, inv_tau, rotor, U: float):
    """Two-sided S_RR, S_LL, S_RL (Eq. 24, 29, 32) as sums over (k2, k3) nodes weighted by ``phi_w``."""
    S_LL, S_RL = node_sums(float(k1), np.ascontiguousarray(k2, dtype=float), np.ascontiguousarray(k3, dtype=float),
                           lidar.beams, lidar.beam_table, lidar.beam_of, lidar.nu_step, lidar.tables, lidar.phase,
                           lidar.gate_of, lidar.scale, lidar.xs.astype(float), np.ascontiguousarray(phi_w, dtype=float),
                           np.ascontiguousarray(inv_tau, dtype=float), np.ascontiguousarray(rotor, dtype=float),
                           float(U))  # fmt: skip
    S_RR = float((rotor**2 * phi_w[0, 0]).sum())
    return S_RR, S_LL, S_RL


def mann_preview_spectra(f_hz, meas: Measurements, params: MannParams, U_m_s: float, radius_m: float,
                         *, kappa_max: float = KAPPA_MAX, n_theta: int = N_THETA,
                         panel_width: float = PANEL_WIDTH, box: BoxLattice | None = None) -> PreviewSpectra:
    """S_RR, S_LL, S_RL of the Mann space-time tensor for a lidar and a rotor (Guo et al. 2023, Eq. 24, 29, 32).

    Parameters
    ----------
    f_hz, meas, params : array_like, Measurements, MannParams
        Positive frequencies [Hz]; one full scan's measurements; Mann model (``evo_time_s`` None: frozen).
    U_m_s, radius_m : float
        Mean wind speed U [m/s], rotor radius R [m].
    kappa_max, panel_width, n_theta : float, float, int, optional
        Upper end of the radial quadrature and its panel width above KAPPA_SPLIT [rad/m]; trapezoid nodes in angle.
    box : BoxLattice, optional
        Sum over this box's (k2, k3) lattice instead (the spectra of what the box holds).

    Returns
    -------
    PreviewSpectra

    Raises
    ------
    ParameterError
        If ``f_hz`` is empty or not positive, U or R is invalid, ``meas`` is empty or a beam has n_1 <= 1e-6.
    """
    f, U, R = _check(f_hz, meas, U_m_s, radius_m)
    k1_all = 2.0 * np.pi * f / U
    if box is None:
        k2, k3, w = polar_nodes(kappa_max, n_theta, panel_width)
    else:
        k2, k3 = lattice_wavenumbers(box)
    kappa = np.hypot(k2, k3)
    z = kappa * R
    rotor = np.where(z > 1e-8, 2.0 * j1(z) / np.where(z > 1e-8, z, 1.0), 1.0)
    lidar = _Lidar(meas, k2, k3, float(np.sqrt(k1_all.max() ** 2 + kappa.max() ** 2)) * 1.01)
    S = np.empty((f.size, 3), dtype=complex)
    for m, k1 in enumerate(k1_all):
        phi_w = sheared_tensor(k1, k2, k3, params) * w if box is None else lattice_tensor(box, k1, params, U)
        tau = evolution_lifetime_s(np.sqrt(k1 * k1 + kappa * kappa), params)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv_tau = np.where(np.isfinite(tau), 1.0 / tau, 0.0)
        S[m] = _node_spectra(lidar, k1, k2, k3, phi_w, inv_tau, rotor, U)
    to_f = 2.0 * 2.0 * np.pi / U  # two-sided in k1 -> one-sided in f
    return PreviewSpectra(f, S[:, 0].real * to_f, S[:, 1].real * to_f, S[:, 2] * to_f)


def rotor_points(radius_m: float, spacing_m: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(y, z) [m] of a square grid of spacing ``spacing_m`` (default R/10) inside the disc of radius ``radius_m`` [m].

    Raises ParameterError if either is not a finite number > 0."""
    R = check_positive("rotor radius (m)", radius_m)
    h = R / 10.0 if spacing_m is None else check_positive("rotor grid spacing (m)", spacing_m)
    n = int(np.floor(R / h))
    c = h * np.arange(-n, n + 1)
    yy, zz = np.meshgrid(c, c, indexing="ij")
    inside = yy**2 + zz**2 <= R * R
    return yy[inside], zz[inside]


def kaimal_preview_spectra(f_hz, meas: Measurements, kparams: KaimalParams, U_m_s: float, radius_m: float,
                           long_coherence, *, long_components: str = "u", vw_coherence: bool = False,
                           rotor_spacing_m: float | None = None, spectra=None, yz_coherence=None) -> PreviewSpectra:
    """S_RR, S_LL, S_RL of the Kaimal direct-product model (Guo et al. 2023, Eq. 25, 31, 33).

    u is coherent in the yz plane (IEC exponential, un-squared); v, w are spatially white unless
    ``vw_coherence``; the rotor is the grid of :func:`rotor_points`.

    Parameters
    ----------
    f_hz, meas, U_m_s, radius_m, kparams
        As :func:`mann_preview_spectra`; ``kparams`` (KaimalParams) the Kaimal spectra and IEC yz coherence.
    long_coherence : callable
        ``long_coherence(dx_m, f_hz)``: un-squared coherence [-] between planes dx [m] apart, for the
        components in ``long_components`` (the others are independent between planes).
    long_components, vw_coherence, rotor_spacing_m : str, bool, float, optional
        Components among "uvw" with longitudinal coherence; give v and w the yz coherence of u; rotor grid
        spacing [m] (default R/10).
    spectra, yz_coherence : callable, optional
        ``spectra(f_hz) -> (3, n)`` one-sided PSDs [m^2/s] and ``yz_coherence(r_m, f_hz)`` [-] (un-squared) in place
        of the Kaimal spectra and IEC coherence of ``kparams`` (a store's user tables, turbgen.theory.user_spectra).

    Returns
    -------
    PreviewSpectra

    Raises
    ------
    ParameterError
        As :func:`mann_preview_spectra`, or if ``rotor_spacing_m`` is not > 0.
    """
    f, U, R = _check(f_hz, meas, U_m_s, radius_m)
    if yz_coherence is None:
        yz_coherence = lambda r_m, f_hz: exponential_yz(r_m, f_hz, U, kparams.a_yz, kparams.lc_m)  # noqa: E731
    S = np.array([kaimal_spectrum(f, s, L, U) for s, L in zip(kparams.sigma_m_s, kparams.length_scales_m)]
                 if spectra is None else spectra(f), dtype=float)  # fmt: skip
    pts = meas.sample_points_m()  # (M, K, 3)
    M, K = meas.weights.shape
    gate_x = np.repeat(meas.focus_m[:, 0], K)
    delay_s = (pts[..., 0] - meas.focus_m[:, None, 0]).ravel() / U  # Taylor shift inside the probe volume
    py, pz = pts[..., 1].ravel(), pts[..., 2].ravel()
    r_ll = np.hypot(py[:, None] - py[None, :], pz[:, None] - pz[None, :])
    dx_ll = np.abs(gate_x[:, None] - gate_x[None, :])
    same_point = (r_ll < 1e-9) & (dx_ll < 1e-9)
    coef = (meas.weights[..., None] * meas.n[:, None, :] / (M * meas.n[:, None, :1])).reshape(M * K, 3)
    yr, zr = rotor_points(R, rotor_spacing_m)
    r_rl = np.hypot(yr[:, None] - py[None, :], zr[:, None] - pz[None, :])
    # the coherences are functions of the separations: evaluated once per distinct value (the same numbers)
    r_ll, r_ll_of = np.unique(r_ll, return_inverse=True)
    dx_ll, dx_ll_of = np.unique(dx_ll, return_inverse=True)
    r_rl, r_rl_of = np.unique(r_rl, return_inverse=True)
    white, same_plane = same_point.astype(float), (dx_ll[dx_ll_of] < 1e-9).astype(float)
    S_LL = np.empty(f.size)
    S_RL = np.empty(f.size, dtype=complex)
    for m, fm in enumerate(f):
        ph = np.exp(2j * np.pi * fm * delay_s)
        coh_u = yz_coherence(r_ll, fm)[r_ll_of]
        gx_coherent = long_coherence(dx_ll, fm)[dx_ll_of]
        total = 0.0
        for c in range(3):
            coh = coh_u if c == 0 or vw_coherence else white
            gx = gx_coherent if "uvw"[c] in long_components else same_plane
            a = coef[:, c] * ph
            total += S[c, m] * np.real(a @ (coh * gx) @ a.conj())
        S_LL[m] = total
        gx_r = long_coherence(gate_x, fm) if "u" in long_components else (gate_x < 1e-9).astype(float)
        coh_r = yz_coherence(r_rl, fm)[r_rl_of]
        S_RL[m] = S[0, m] * (coh_r.mean(axis=0) * gx_r) @ (coef[:, 0] * ph).conj()
    S_RR = rews_spectrum_kaimal(f, kparams, U, yr, zr, s1=S[0], yz_coherence=yz_coherence)
    return PreviewSpectra(f, S_RR, S_LL, S_RL)
