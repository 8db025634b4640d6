"""Theory side of the validation: what the store's model predicts for every estimate, on the store's grid.

Both generators synthesise a periodic record of nt samples, i.e. spectral *lines* at
f_j = j / (nt dt), j = 0 .. nt/2 (a real field: the lines -f_j are the complex conjugates). A
field is described here by the two-sided line variances L_j = E|Z_j|^2 [m^2 s^-2] of
x(t) = sum_j Z_j exp(i 2 pi f_j t) (one-sided variance of a line pair: 2 L_j), and by the line
cross-covariances E[conj(Z_j^a) Z_j^b] between two points or components.

* Kaimal (paper 000 Eq. 11): L_j = S_i(f_j) df / 2 with the one-sided Kaimal PSD S_i, L_0 = 0
  (no mean); times sigma_i^2 / sum(2 L_j) when the store says the spectrum was rescaled. u yz
  cross-covariance L_j coh(r, f_j) with the IEC exponential coherence (Eq. 12, un-squared);
  v, w as the store says (white, or the same exponential); between planes the longitudinal
  model of the store (Eq. 18 / Simley-Pao / Kristensen, un-squared, zero phase in the
  convected frame) for the components it was applied to, independent otherwise. REWS: Eq. 25
  over the rotor points of the grid.
* Mann (paper 000 Eq. 8, 13, 24): the generator samples the spectral tensor on the lattice of
  its periodic (xi = U t, y, z) box, nt x nyp x nzp points spaced U dt, dy, dz. The expected
  field therefore has L_j = sum over the (k2, k3) lattice of Phi_ii(k1_j, k2, k3) dk1 dk2 dk3,
  k1_j = 2 pi f_j / U: the Mann spectrum *as the grid resolves it* -- band-limited at the
  y, z Nyquist wavenumbers pi/dy, pi/dz and missing the wavenumbers below 2 pi/(nyp dy),
  2 pi/(nzp dz) of the finite box (Mann 1998). Cross-covariances use exp(i(k2 dy + k3 dz)) and
  the space-time tensor Theta = exp(-dx/(U tau_e)) Phi (Eq. 13) between planes dx apart; the
  REWS uses Phi_11 |H_R(k2, k3)|^2 with H_R the average of exp(i k.r) over the rotor points of
  the grid (Eq. 24 with the grid's points instead of the continuous disc).
  The tensor is evaluated here from turbgen.theory (not from the generator's stencil), so the
  validator checks the generator's factorisation too.

The Welch estimate of a bin is a weighted sum of lines (:class:`WelchKernel`, exact for the
Hann window with the per-segment mean removed), so the expected estimate is computed exactly,
also in the lowest bins where leakage and mean removal matter.

Correlation of estimates across points (for the tolerances in ``verdict``): for Gaussian
fields, Cov(|X_p|^2, |X_q|^2) = E|X_p|^2 E|X_q|^2 coh2_pq (Isserlis), so an average over N points
(and planes) has the variance of one point times rho_bar = sum_pq coh2_pq / N^2. ``rho_*`` hold
rho_bar for every averaged point set, from the model's magnitude-squared coherence between all
the points (including different planes), at ``node_f``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.interpolate import CubicSpline

from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.theory.coherence_models import LONGITUDINAL_MODELS, exponential_yz
from turbgen.theory.eddy_lifetime import evolution_lifetime_s
from turbgen.theory.kaimal import kaimal_spectrum
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import KaimalParams, MannParams
from turbgen.validate.estimators import COMPONENTS, WelchSetup

KERNEL_BAND = 32  # Welch bins either side of a bin whose lines are summed (Hann leakage beyond < 1e-8)
N_LINE_NODES = 96  # k1 nodes of the Mann lattice sums when not every line is evaluated
N_RHO_NODES = 24  # frequency nodes of the correlation sums rho_bar
EXACT_LATTICE_POINTS = 4_000_000  # evaluate every line exactly when lines x lattice points is below this


class WelchKernel:
    """Expected one-sided Welch estimate of bins m = 0 .. n/2 as a weighted sum of spectral lines.

    A segment's windowed, mean-removed DFT is X_m = sum_j Z_j G_m(f_j) with
    G_m(f) = W(m/n - f dt) - e(f) W(m/n), W the window's DTFT and e(f) the segment mean of
    exp(i 2 pi f t); so E[P_m] = scale_m sum_j |G_m(f_j)|^2 L_j over the lines +-f_j (the
    line -f_j carries conj(L_j); G is periodic in f with period 1/dt, which folds the partners
    of lines near the Nyquist frequency back). Lines more than KERNEL_BAND bins away are
    ignored (Hann sidelobes fall as bin^-3).
    """

    def __init__(self, setup: WelchSetup, nt: int):
        n, dt = setup.nperseg, setup.dt_s
        self.setup, self.nt = setup, nt
        ratio = nt / n  # lines per Welch bin
        m = np.arange(n // 2 + 1)
        width = min(int(math.ceil(KERNEL_BAND * ratio)), (nt - 1) // 2)  # each line (mod nt) at most once per bin
        e = np.round(m * ratio).astype(int)[:, None] + np.arange(-width, width + 1)[None, :]  # extended line index
        e_mod = np.mod(e, nt)
        half = nt // 2
        self.conj = e_mod > half  # frequency e/(nt dt) = -(nt - e_mod)/(nt dt): the conjugate partner
        self.idx = np.where(self.conj, nt - e_mod, e_mod)
        weight = self._g(m[:, None], e / (nt * dt), n, dt)
        self.k = setup.scale[:, None] * np.abs(weight) ** 2
        self.k[self.idx == 0] = 0.0  # the mean (j = 0) is removed from every segment

    @staticmethod
    def _dirichlet(nu, n):
        z = np.exp(-2j * np.pi * nu)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = (1.0 - z**n) / (1.0 - z)
        return np.where(np.abs(np.sin(np.pi * nu)) < 1e-12, complex(n), d)

    @classmethod
    def _window_dtft(cls, nu, n):
        """DTFT of the periodic Hann window 0.5 - 0.5 cos(2 pi t / n), t = 0 .. n-1."""
        d = cls._dirichlet
        return 0.5 * d(nu, n) - 0.25 * d(nu - 1.0 / n, n) - 0.25 * d(nu + 1.0 / n, n)

    @classmethod
    def _g(cls, m, f, n, dt):
        mean_e = cls._dirichlet(-f * dt, n) / n
        return cls._window_dtft(m / n - f * dt, n) - mean_e * cls._window_dtft(m / n + 0.0 * f, n)

    def apply(self, lines: np.ndarray) -> np.ndarray:
        """Expected Welch estimate (n/2+1,) of line (cross-)variances ``lines`` (nt/2+1,), real or complex."""
        lines = np.asarray(lines)
        vals = lines[self.idx]
        if np.iscomplexobj(lines):
            vals = np.where(self.conj, np.conj(vals), vals)
        return np.sum(self.k * vals, axis=1)


@dataclass
class Theory:
    """Model predictions on the store's grid (see module docstring). Lines are indexed j = 0 .. nt/2."""

    model: str
    nt: int
    line_f: np.ndarray
    auto: dict  # component -> (nl,) L_j
    yz: dict  # component -> {(a, b): (nl,) complex}
    long: dict  # |dx| rounded to 1e-6 m -> (nl,) u line covariance between planes (same y, z)
    rews: np.ndarray  # (nl,) rotor-effective wind speed lines
    node_f: np.ndarray  # (nn,) frequencies of the rho_bar nodes [Hz]
    rho_all: dict  # component -> (nn,) over all points and planes
    rho_yz: dict  # component -> {(a, b): (nn,)} over the first points of the pairs, all planes
    rho_long: np.ndarray  # (nn,) over the plane-pair sub-lattice, one plane
    rho_rews: np.ndarray  # (nn,) over the planes (REWS series)
    sigma_model: dict  # component -> sigma of the full model spectrum [m/s] (information)
    band: dict  # what the grid resolves (stated in the report)
    uw: np.ndarray | None = None  # (nl,) u-w line covariance (Mann F13; 0 for Kaimal)
    rho_uw: np.ndarray | None = None  # (nn,) cross-component term of the uw variance bound
    long_components: str = "u"
    auto_model: dict | None = None  # Mann: component -> (nl,) lines of the continuous model band-limited to the grid
    reference: dict = field(default_factory=dict)  # continuous-model curves for the plots: name -> (f, S)

    def long_lines(self, dx_m: float) -> np.ndarray:
        return self.long[_dx_key(dx_m)]

    def rho(self, values: np.ndarray, f_hz) -> np.ndarray:
        """rho_bar node values interpolated (linear in log f) to ``f_hz``, clipped to [0, 1]."""
        f = np.clip(np.asarray(f_hz, dtype=float), self.node_f[0], self.node_f[-1])
        return np.clip(np.interp(np.log(f), np.log(self.node_f), values), 0.0, 1.0)

    @property
    def pair_weights(self) -> np.ndarray:
        """Weight of line j in a variance: 2 (lines +-f_j), 1 for j = 0 and the single Nyquist line."""
        return _pair_weights(self.line_f.size, self.nt % 2 == 0)

    def variance(self, component: str) -> float:
        """Expected variance about each point's record mean: all lines but j = 0 [m^2 s^-2]."""
        return float(np.sum(self.pair_weights[1:] * self.auto[component][1:]))

    def band_variance(self, component: str) -> float:
        """Variance of the continuous model band-limited to the record's lines and the grid's Nyquist
        rectangle, without the box's point sampling (Mann; Kaimal: = variance) [m^2 s^-2]."""
        lines = self.auto[component] if self.auto_model is None else self.auto_model[component]
        return float(np.sum(self.pair_weights[1:] * lines[1:]))


def _pair_weights(nl: int, nt_even: bool = True) -> np.ndarray:
    """Lines j and -j together: weight 2, except j = 0 and the single Nyquist line (weight 1)."""
    w = np.full(nl, 2.0)
    w[0] = 1.0
    if nt_even:
        w[-1] = 1.0
    return w


def _dx_key(dx_m: float) -> float:
    return round(abs(float(dx_m)), 6)


def plane_separations(grid: Grid) -> dict:
    """Distinct |x_p - x_q| [m] over ordered plane pairs -> number of pairs."""
    out: dict = {}
    for xp in grid.x_m:
        for xq in grid.x_m:
            k = _dx_key(xp - xq)
            out[k] = out.get(k, 0) + 1
    return out


def _rect_counts(ny: int, nz: int, my: int, mz: int) -> np.ndarray:
    """Pairs of points of an my x mz rectangle per separation (dy, dz) on the (2ny-1, 2nz-1) lag grid."""
    dy = np.arange(-(ny - 1), ny)
    dz = np.arange(-(nz - 1), nz)
    return np.maximum(my - np.abs(dy), 0)[:, None] * np.maximum(mz - np.abs(dz), 0)[None, :].astype(float)


def _set_counts(ny: int, nz: int, iy: np.ndarray, iz: np.ndarray) -> np.ndarray:
    """Pairs of points of the sub-lattice iy x iz per separation on the (2ny-1, 2nz-1) lag grid."""
    cy = np.zeros(2 * ny - 1)
    cz = np.zeros(2 * nz - 1)
    np.add.at(cy, (iy[:, None] - iy[None, :]).ravel() + ny - 1, 1.0)
    np.add.at(cz, (iz[:, None] - iz[None, :]).ravel() + nz - 1, 1.0)
    return cy[:, None] * cz[None, :]


def _lag_radius(grid: Grid) -> np.ndarray:
    """|r| [m] on the (2ny-1, 2nz-1) lag grid."""
    dy = np.arange(-(grid.ny - 1), grid.ny) * grid.dy_m
    dz = np.arange(-(grid.nz - 1), grid.nz) * grid.dz_m
    return np.hypot(dy[:, None], dz[None, :])


class _RhoAccumulator:
    """Sums of coh2 over all ordered pairs of every averaged point set (see module docstring)."""

    def __init__(self, grid: Grid, seps, iy, iz, nn: int):
        self.grid, self.seps = grid, seps
        ny, nz, nx = grid.ny, grid.nz, grid.nx
        self.counts_all = _rect_counts(ny, nz, ny, nz)
        self.counts_yz = {s: _rect_counts(ny, nz, ny - s[0], nz - s[1]) for s in seps}
        self.counts_long = _set_counts(ny, nz, iy, iz)
        self.norm_all = (nx * ny * nz) ** 2
        self.norm_yz = {s: (nx * (ny - s[0]) * (nz - s[1])) ** 2 for s in seps}
        self.norm_long = (iy.size * iz.size) ** 2
        self.all = {c: np.zeros(nn) for c in COMPONENTS}
        self.yz = {c: {s: np.zeros(nn) for s in seps} for c in COMPONENTS}
        self.long = np.zeros(nn)
        self.uw = np.zeros(nn)

    def add(self, component: str, coh2: np.ndarray, multiplicity: int, same_plane: bool, n=slice(None)) -> None:
        """Add coh2 (nodes, 2ny-1, 2nz-1) between the points of two planes at nodes ``n``.

        ``multiplicity``: number of ordered plane pairs with this separation.
        """
        self.all[component][n] += multiplicity * np.einsum("nij,ij->n", coh2, self.counts_all) / self.norm_all
        for s in self.seps:
            self.yz[component][s][n] += (
                multiplicity * np.einsum("nij,ij->n", coh2, self.counts_yz[s]) / self.norm_yz[s]
            )
        if same_plane and component == "u":
            self.long[n] += np.einsum("nij,ij->n", coh2, self.counts_long) / self.norm_long

    def add_uw(self, coh2: np.ndarray, multiplicity: int, n=slice(None)) -> None:
        """|u-w coherency|^2 between points of two planes, as :meth:`add`."""
        self.uw[n] += multiplicity * np.einsum("nij,ij->n", coh2, self.counts_all) / self.norm_all


def _rotor_pair_counts(grid: Grid, mask: np.ndarray) -> np.ndarray:
    """Pairs of rotor points per lag on the (2ny-1, 2nz-1) lag grid (autocorrelation of the mask)."""
    sy, sz = 2 * grid.ny - 1, 2 * grid.nz - 1
    f = np.fft.rfft2(mask.astype(float), s=(sy, sz))
    ac = np.fft.irfft2(np.abs(f) ** 2, s=(sy, sz))
    return np.round(np.fft.fftshift(ac, axes=(0, 1)))


def _band(setup: WelchSetup, grid: Grid, U: float) -> dict:
    f_lo, f_hi = 1.0 / (setup.nperseg * setup.dt_s), 0.5 / setup.dt_s
    return {
        "f_min_hz": f_lo,
        "f_max_hz": f_hi,
        "k1_min_rad_m": 2 * np.pi * f_lo / U,
        "k1_max_rad_m": 2 * np.pi * f_hi / U,
        "welch_df_hz": f_lo,
        "record_df_hz": 1.0 / (grid.nt * grid.dt_s),
        "k2_nyquist_rad_m": np.pi / grid.dy_m,
        "k3_nyquist_rad_m": np.pi / grid.dz_m,
    }


def _node_freqs(setup: WelchSetup, nt: int) -> np.ndarray:
    """rho_bar nodes from the lowest record line 1/(nt dt) (the variance needs it) to the Nyquist frequency."""
    return np.geomspace(1.0 / (nt * setup.dt_s), setup.freqs[-1], N_RHO_NODES)


# ----------------------------------------------------------------------------------------------- Kaimal


def kaimal_theory(attrs: dict, grid: Grid, setup: WelchSetup, seps, mask, iy, iz) -> Theory:
    """Kaimal / IEC expectations from the store attributes written by turbgen.runs.kaimal."""
    p = attrs["parameters"]
    U = float(attrs["U_m_s"])
    try:
        kp = KaimalParams(tuple(p["sigma_m_s"]), tuple(p["length_scales_m"]), p["a_yz"], p["lc_m"])
        long_model, long_components = p["long_model"], p["long_components"]
        vw_coherent = p.get("vw_coherence", "white") == "exp"
        rescale = bool(p.get("rescale", False))
    except (KeyError, TypeError) as exc:
        raise ParameterError(f"store parameters lack the Kaimal model ({exc}); not a turbgen Kaimal store") from None
    if long_model == "exp":
        long_fn = lambda dx, f: LONGITUDINAL_MODELS["exp"](dx, f, U, p["a_x"], p["b_x"])  # noqa: E731
    else:
        s_tot = math.sqrt(sum(s * s for s in kp.sigma_m_s))
        long_fn = lambda dx, f: LONGITUDINAL_MODELS[long_model](dx, f, U, s_tot, kp.length_scales_m[0])  # noqa: E731
    nt, dt = grid.nt, grid.dt_s
    line_f = np.arange(nt // 2 + 1) / (nt * dt)
    df = line_f[1]
    auto = {}
    for i, c in enumerate(COMPONENTS):
        lines = kaimal_spectrum(line_f, kp.sigma_m_s[i], kp.length_scales_m[i], U) * df / 2.0  # Eq. 11
        lines[0] = 0.0
        if rescale:
            lines *= kp.sigma_m_s[i] ** 2 / np.sum(_pair_weights(lines.size, nt % 2 == 0) * lines)
        auto[c] = lines

    def yz_coh(c, r_m, f):
        if c == "u" or vw_coherent:
            return exponential_yz(r_m, f, U, kp.a_yz, kp.lc_m)  # Eq. 12, un-squared
        return np.where(np.asarray(r_m) == 0, 1.0, 0.0) * np.ones_like(f)

    yz = {c: {(a, b): auto[c] * yz_coh(c, math.hypot(a * grid.dy_m, b * grid.dz_m), line_f) for a, b in seps}
          for c in COMPONENTS}
    long = {dx: auto["u"] * long_fn(dx, line_f) for dx in plane_separations(grid)}
    # Eq. 25: S_RR = S_1 / n_R^2 sum_ij coh(r_ij, f), summed over the rotor pairs per lag
    counts = _rotor_pair_counts(grid, mask)
    radius = _lag_radius(grid)
    sel = counts > 0
    n_r = mask.sum()
    rews_factor = np.array([np.sum(counts[sel] * exponential_yz(radius[sel], f, U, kp.a_yz, kp.lc_m)) for f in line_f])
    rews = auto["u"] * rews_factor / n_r**2

    node_f = _node_freqs(setup, grid.nt)
    acc = _RhoAccumulator(grid, seps, iy, iz, node_f.size)
    lag_r = _lag_radius(grid)
    for c in COMPONENTS:
        coh_yz2 = np.stack([yz_coh(c, lag_r, np.full(lag_r.shape, f)) ** 2 for f in node_f])
        for dx, mult in plane_separations(grid).items():
            if dx == 0:
                acc.add(c, coh_yz2, mult, same_plane=True)
            elif c in long_components:
                acc.add(c, coh_yz2 * (long_fn(dx, node_f) ** 2)[:, None, None], mult, same_plane=False)
    rho_rews = np.zeros(node_f.size)
    for dx, mult in plane_separations(grid).items():
        rho_rews += mult * long_fn(dx, node_f) ** 2 / grid.nx**2
    reference = {
        f"spectrum_{c}": (line_f[1:], kaimal_spectrum(line_f[1:], kp.sigma_m_s[i], kp.length_scales_m[i], U))
        for i, c in enumerate(COMPONENTS)
    }
    band = _band(setup, grid, U)
    band["note"] = (
        f"Kaimal lines f_j = j/(nt dt) up to the Nyquist frequency {band['f_max_hz']:g} Hz; "
        + ("spectra rescaled to the nominal sigma (store attribute rescale)" if rescale
           else "variance = the Kaimal integral over the resolved band (no rescaling)")
    )
    return Theory(
        model="kaimal", nt=nt, line_f=line_f, auto=auto, yz=yz, long=long, rews=rews, node_f=node_f,
        rho_all=acc.all, rho_yz=acc.yz, rho_long=acc.long, rho_rews=rho_rews,
        sigma_model=dict(zip(COMPONENTS, kp.sigma_m_s)), band=band, long_components=long_components,
        uw=np.zeros(line_f.size), rho_uw=np.zeros(node_f.size),  # u and w are synthesised independently
        reference=reference,
    )


# ------------------------------------------------------------------------------------------------- Mann


@dataclass(frozen=True)
class MannBox:
    """The generator's periodic box in y, z: nyp x nzp points spaced dy, dz (the grid is its corner)."""

    nyp: int
    nzp: int


def _lattice(grid: Grid, box: MannBox):
    """(k2, k3) lattice of the box [rad/m], (nyp, nzp) each, FFT order (k2 Nyquist positive, as synthesised)."""
    j = np.arange(box.nyp)
    k2 = np.where(j <= box.nyp // 2, j, j - box.nyp) * (2 * np.pi / (box.nyp * grid.dy_m))
    k3 = np.fft.fftfreq(box.nzp, d=grid.dz_m) * 2 * np.pi
    return np.meshgrid(k2, k3, indexing="ij")


def _lags(field2d: np.ndarray, ny: int, nz: int) -> np.ndarray:
    """Values at lags -(n-1) .. n-1 (periodic box index lag mod nyp) -> (..., 2ny-1, 2nz-1)."""
    iy = np.arange(-(ny - 1), ny) % field2d.shape[-2]
    iz = np.arange(-(nz - 1), nz) % field2d.shape[-1]
    return field2d[..., iy[:, None], iz[None, :]]


CELL_RADIUS = 2  # cells |k2| <= 2 dk2, |k3| <= 2 dk3 around the k1 axis are integrated, not point-sampled
CELL_K1_MAX = 8.0  # ... for |k1| <= 8 max(dk2, dk3); beyond, Phi is smooth on the cell scale there
CELL_GAUSS = 4


@lru_cache(maxsize=8)
def _leggauss(n: int):
    return np.polynomial.legendre.leggauss(n)


def _gauss(a: float, b: float, n: int = CELL_GAUSS):
    x, w = _leggauss(n)
    return 0.5 * (b - a) * x + 0.5 * (a + b), 0.5 * (b - a) * w


def _graded(center: float, width: float, scale: float):
    """Nodes/weights over a cell of ``width`` around ``center``; halving panels towards 0 down to ``scale``."""
    if center != 0.0:
        return _gauss(center - width / 2, center + width / 2)
    edges = [width / 2]
    while edges[-1] > scale and len(edges) < 40:
        edges.append(edges[-1] / 2)
    edges = np.array([0.0, *edges[::-1]])
    x = np.concatenate([_gauss(a, b)[0] for a, b in zip(edges[:-1], edges[1:])])
    w = np.concatenate([_gauss(a, b)[1] for a, b in zip(edges[:-1], edges[1:])])
    return np.concatenate([-x[::-1], x]), np.concatenate([w[::-1], w])


class _MannLattice:
    """Mann tensor and space-time decay on the (k2, k3) lattice of the box, slab by slab in k1.

    Each lattice point stands for its cell: the point value Phi(k) dk1 dk2 dk3 is used except in
    the cells around the k1 axis at small k1, where Phi varies strongly inside a cell (on the axis
    Phi_33 = E(k0)/(4 pi k1^2) with k0 -> Gamma a / L finite) and the cell integral is computed
    (Gauss rules graded towards the axis down to the scale |k1|; Mann 1998). The generator does the
    same (turbgen.synthesis.mann_stencil), with its own rule, so this is an independent check of it.
    """

    def __init__(self, params: MannParams, grid: Grid, box: MannBox, U: float):
        self.params, self.grid, self.box, self.U = params, grid, box, U
        self.k2, self.k3 = _lattice(grid, box)
        self.dk1 = dk1 = 2 * np.pi / (grid.nt * grid.dt_s * U)
        self.dk2, self.dk3 = 2 * np.pi / (box.nyp * grid.dy_m), 2 * np.pi / (box.nzp * grid.dz_m)
        self.dk = dk1 * self.dk2 * self.dk3
        self.r2 = min(CELL_RADIUS, (box.nyp - 1) // 2)
        self.r3 = min(CELL_RADIUS, (box.nzp - 1) // 2)

    def _axis_cells(self, k1: float) -> np.ndarray:
        """∫_cell Phi dk over the (2 r2 + 1) x (2 r3 + 1) cells around the axis at k1, (3, 3, 2r2+1, 2r3+1)."""
        x1, w1 = _gauss(k1 - self.dk1 / 2, k1 + self.dk1 / 2, 2)
        scale = max(abs(k1), self.dk1 / 4)
        rules2 = [_graded(j * self.dk2, self.dk2, scale) for j in range(-self.r2, self.r2 + 1)]
        rules3 = [_graded(l * self.dk3, self.dk3, scale) for l in range(-self.r3, self.r3 + 1)]
        pts, wts, starts = [], [], []
        for x2, w2 in rules2:
            for x3, w3 in rules3:
                starts.append(sum(p.shape[1] for p in pts))
                g = np.meshgrid(x1, x2, x3, indexing="ij")
                pts.append(np.stack([a.ravel() for a in g]))
                wts.append((w1[:, None, None] * w2[None, :, None] * w3[None, None, :]).ravel())
        k = np.concatenate(pts, axis=1)
        phi = sheared_tensor(k[0], k[1], k[2], self.params) * np.concatenate(wts)  # one call for all cells
        cells = np.add.reduceat(phi, starts, axis=2)
        return cells.reshape(3, 3, len(rules2), len(rules3))

    def slabs(self, k1: np.ndarray, batch: int = 8):
        """Yield (index, Phi (3, 3, nyp, nzp) times dk1 dk2 dk3 (cell integrals), 1/tau_e (nyp, nzp) [1/s]) per k1."""
        iy = np.arange(-self.r2, self.r2 + 1) % self.box.nyp
        iz = np.arange(-self.r3, self.r3 + 1) % self.box.nzp
        k1_cells = CELL_K1_MAX * max(self.dk2, self.dk3)
        for i0 in range(0, k1.size, batch):
            kk = k1[i0 : i0 + batch][:, None, None]
            # the generator's slab of time frequency f holds k1 = -2 pi f / U (time reversal, see
            # synthesis.mann_stencil); Phi(-k1, k2, k3) differs from Phi(k1, k2, k3) on the unpaired Nyquist rows
            phi = sheared_tensor(-kk, self.k2[None], self.k3[None], self.params) * self.dk
            kmag = np.sqrt(kk * kk + self.k2[None] ** 2 + self.k3[None] ** 2)
            with np.errstate(divide="ignore"):
                inv_tau = 1.0 / evolution_lifetime_s(kmag, self.params)  # Eq. 15 (0 when frozen)
            for n in range(kk.shape[0]):
                p = phi[:, :, n]
                k1n = float(kk[n, 0, 0])
                if k1n <= k1_cells:
                    cells = self._axis_cells(-k1n)
                    if k1n == 0.0:
                        cells[:, :, self.r2, self.r3] = 0.0  # the box mean (k = 0) carries no energy
                    p[:, :, iy[:, None], iz[None, :]] = cells
                yield i0 + n, p, inv_tau[n]


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
    """Continuous F_ii(k1) = ∫ Phi_ii dk2 dk3 over the grid's Nyquist rectangle |k2| <= pi/dy, |k3| <= pi/dz.

    Returns (3, len(k1)) [m^3 s^-2], two-sided in k1. Polar quadrature: Gauss-Legendre in angle on the
    four sectors between the rectangle's corners (kappa_max(theta) = k_N / |cos| or / |sin| is smooth
    inside each), Gauss panels in ln kappa from 1e-7 s to kappa_max (s = sqrt(k1^2 + L^-2)), which
    resolves the peak of Phi_33 near kappa ~ k1 at small k1. This is the model the grid can represent,
    without the point sampling of a finite box.
    """
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


def mann_params_from_attrs(p: dict) -> MannParams:
    """MannParams from the store's ``parameters`` attribute (written by turbgen.runs.mann)."""
    try:
        return MannParams(ae=p["ae"], length_scale_m=p["length_scale_m"], gamma=p["gamma"], lifetime=p["lifetime"],
                          factor1=p["factor1"], factor2=p["factor2"], evo_time_s=p["evo_time_s"])
    except (KeyError, TypeError) as exc:
        raise ParameterError(f"store parameters lack the Mann model ({exc}); not a turbgen Mann store") from None


def mann_box_from_attrs(p: dict, grid: Grid) -> MannBox:
    """The synthesis box: pad_yz times the grid in y and z (turbgen.runs.mann.MannRun.box)."""
    try:
        pad = int(p["pad_yz"])
        return MannBox(pad * grid.ny, pad * grid.nz)
    except (KeyError, TypeError, ValueError) as exc:
        raise ParameterError(f"store parameters lack the Mann box size ({exc})") from None


def mann_theory(attrs: dict, grid: Grid, setup: WelchSetup, seps, mask, iy, iz) -> Theory:
    """Mann space-time expectations on the lattice of the generator's box (module docstring)."""
    p = attrs["parameters"]
    params = mann_params_from_attrs(p)
    box = mann_box_from_attrs(p, grid)
    U = float(attrs["U_m_s"])
    lat = _MannLattice(params, grid, box, U)
    nt, dt = grid.nt, grid.dt_s
    line_f = np.arange(nt // 2 + 1) / (nt * dt)
    k1_lines = 2 * np.pi * line_f / U
    if line_f.size * box.nyp * box.nzp <= EXACT_LATTICE_POINTS:
        k1_nodes = k1_lines
    else:
        k1_nodes = np.concatenate([[0.0], np.geomspace(k1_lines[1], k1_lines[-1], N_LINE_NODES)])
    dxs = plane_separations(grid)
    # rotor average transfer |H_R|^2 on the lattice (the grid's rotor points inside the box)
    mask_box = np.zeros((box.nyp, box.nzp))
    mask_box[: grid.ny, : grid.nz] = mask
    h2 = np.abs(np.fft.fft2(mask_box)) ** 2 / mask.sum() ** 2
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
    exact = k1_nodes is k1_lines
    auto = {c: f_nodes[c] if exact else _interp_lines(k1_nodes, f_nodes[c], k1_lines, True) for c in COMPONENTS}

    def ratio_lines(values, ref):
        return values if exact else _interp_lines(k1_nodes, values / ref, k1_lines, False)

    # the continuous model band-limited to the grid (sigma_i metrics), smooth in k1: interpolated log-log
    bl_k1 = np.geomspace(k1_lines[1], k1_lines[-1], N_RHO_NODES)
    band_lim = band_limited_spectra(params, grid, bl_k1)
    auto_model = {}
    for i, c in enumerate(COMPONENTS):
        spline = CubicSpline(np.log(bl_k1), np.log(band_lim[i]))
        auto_model[c] = np.concatenate([[0.0], np.exp(spline(np.log(k1_lines[1:]))) * lat.dk1])
    norm13 = np.sqrt(f_nodes["u"] * f_nodes["w"])
    uw = f13 if exact else ratio_lines(f13, norm13) * np.sqrt(auto["u"] * auto["w"])
    yz = {c: {s: yz_nodes[c][s] if exact else ratio_lines(yz_nodes[c][s], f_nodes[c]) * auto[c] for s in seps}
          for c in COMPONENTS}
    long = {dx: v if exact else ratio_lines(v, f_nodes["u"]) * auto["u"] for dx, v in long_nodes.items()}
    rews = rews_nodes if exact else ratio_lines(rews_nodes, f_nodes["u"]) * auto["u"]

    # rho_bar at the nodes: coh2 over all lags from the 2-D FFT of Theta_ii on the lattice
    node_f = _node_freqs(setup, grid.nt)
    acc = _RhoAccumulator(grid, seps, iy, iz, node_f.size)
    rho_rews = np.zeros(node_f.size)
    size = box.nyp * box.nzp
    for n, phi, inv_tau in lat.slabs(2 * np.pi * node_f / U):
        sl = slice(n, n + 1)
        diag = [phi[i, i].sum() for i in range(3)]
        r0 = np.sum(phi[0, 0] * h2)
        for dx, mult in dxs.items():
            decay = np.exp(-dx / U * inv_tau)
            for i, c in enumerate(COMPONENTS):
                cross = _lags(np.fft.ifft2(phi[i, i] * decay) * size, grid.ny, grid.nz)
                acc.add(c, np.abs(cross[None]) ** 2 / diag[i] ** 2, mult, dx == 0, sl)
            cross13 = _lags(np.fft.ifft2(phi[0, 2] * decay) * size, grid.ny, grid.nz)
            acc.add_uw(np.abs(cross13[None]) ** 2 / (diag[0] * diag[2]), mult, sl)
            rho_rews[n] += mult * (np.sum(phi[0, 0] * decay * h2) / r0) ** 2 / grid.nx**2
    band = _band(setup, grid, U)
    band.update(
        box_y_m=box.nyp * grid.dy_m,
        box_z_m=box.nzp * grid.dz_m,
        k2_min_rad_m=2 * np.pi / (box.nyp * grid.dy_m),
        k3_min_rad_m=2 * np.pi / (box.nzp * grid.dz_m),
        note=(
            "Mann tensor summed over the box lattice (cells at the k1 axis integrated): |k2| <= pi/dy, "
            f"|k3| <= pi/dz, spacing 2 pi/box size; box {box.nyp} x {box.nzp} points "
            f"({box.nyp * grid.dy_m:g} m x {box.nzp * grid.dz_m:g} m)"
        ),
    )
    from turbgen.theory.mann_spectra import variances

    var = variances(params)
    return Theory(
        model="mann", nt=nt, line_f=line_f, auto=auto, yz=yz, long=long, rews=rews, node_f=node_f,
        rho_all=acc.all, rho_yz=acc.yz, rho_long=acc.long, rho_rews=rho_rews,
        sigma_model={c: math.sqrt(var[c + c]) for c in COMPONENTS}, band=band, uw=uw, rho_uw=acc.uw,
        long_components="u", auto_model=auto_model, reference=_mann_reference(params, setup, U, mask, grid),
    )


def _mann_reference(params: MannParams, setup: WelchSetup, U: float, mask, grid: Grid) -> dict:
    """Continuous-model curves (infinite box, no grid cut-off) for the plots: one-sided S(f) = 2 F(k1) 2 pi / U."""
    from turbgen.theory.mann_spectra import one_point_spectra

    f = np.geomspace(setup.freqs[1], setup.freqs[-1], 64)
    k1 = 2 * np.pi * f / U
    spec = one_point_spectra(k1, params)
    conv = 2.0 * 2 * np.pi / U
    out = {f"spectrum_{c}": (f, conv * spec[name]) for c, name in zip(COMPONENTS, ("F11", "F22", "F33"))}
    out["uw_cross_spectrum"] = (f, conv * spec["F13"])
    from turbgen.theory.rotor_effective import rews_spectrum_mann

    # Eq. 24 for the continuous disc of the rotor radius (the expectation uses the grid's rotor points)
    radius = float(np.sqrt(mask.sum() * grid.dy_m * grid.dz_m / np.pi))
    out["rews_spectrum"] = (f[::2], conv * rews_spectrum_mann(k1[::2], params, radius))
    return out


def theory_for(fs, setup: WelchSetup, seps, mask, iy, iz) -> Theory:
    """The Theory of the store's model."""
    if fs.model == "mann":
        return mann_theory(fs.attrs, fs.grid, setup, seps, mask, iy, iz)
    return kaimal_theory(fs.attrs, fs.grid, setup, seps, mask, iy, iz)
