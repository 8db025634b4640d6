"""Fit the eddy-evolution time gamma [s] (Guo et al. 2022) to the longitudinal coherence of u along x.

Estimate: pairs of u points at different x and one (y, z) (a store's planes) or one height (sensors, in the wind's
frame: two masts may be apart across the wind too); per pair of positions (x, y) and band the co-coherence r = sum Re
C_ij / sqrt(sum A_i sum A_j) pools the Welch cross- and auto-spectra (``spectra``) over the layout's points and the
band's bins. Sensor series are first shifted by whole samples of Taylor's delay x / U; the rest delta (< dt / 2) gives
the model's co-coherence a factor cos(2 pi f delta) per line. A store is in the convected frame. Model: rho(k1, dx, dy)
= sum Phi_11 exp(i k2 dy) exp(-dx / (U tau_e(k))) / sum Phi_11 (Guo et al. 2023, Eq. 8, 13, 16; dy = 0 on a lattice)
over the store's lattice (``MannLattice``; also for series sampled from a store, ``Sampler``) or the continuous (k2, k3)
plane (``perpendicular_quadrature``), ae, L and Gamma held at their one-point fit (factor2 at its default); through the
expected Welch estimate (``WelchKernel``), the band means and each point's probe-volume power gain (lidar gates).
Variance (delta method with Isserlis 1918 moments; Z_m as in ``kaimal_coherence``): Cov(r_m, r_n) = tr(M_m R M_n R) c, R
the (x, x) coherencies, c the one-point variance factor of a band's auto-spectrum (``spectra``); one pair gives (1 -
rho^2)^2 c / 2, and E r = rho - rho (1 - rho^2) c / 4. Bands covary through ``BandSpectra.band_corr``.

Fit: chi^2 over ln gamma on the range of evo (scan, bounded refinement), re-weighted at the fitted gamma until ln
gamma moves < MOVE_TOL. 95 % interval: chi^2 <= min + 3.84 with ae, L, Gamma held (``ci95_held``), each side widened
in quadrature by 1.96 x the one-point fit's share (``_sensitivity``, ``_propagated``). An interval reaching the top
of the range does not exclude the frozen field (gamma -> inf): gamma is then not identified, and the result says so."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import cast

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import brentq, minimize_scalar

from turbgen.grid import Grid
from turbgen.theory import ranges
from turbgen.theory.eddy_lifetime import evolution_lifetime_s
from turbgen.theory.mann_quadrature import perpendicular_quadrature
from turbgen.theory.params import MannParams
from turbgen.validation.fit.covariance import point_sets, separations
from turbgen.validation.fit.data import FitData, in_wind_frame
from turbgen.validation.fit.evo_cross import coherence_spectra_corr, cross_covariance
from turbgen.validation.fit.mann import Z95
from turbgen.validation.fit.model import BandModel
from turbgen.validation.fit.result import MannFit
from turbgen.validation.fit.spectra import estimate_bands, segment_dfts
from turbgen.validation.mann_lattice import MannLattice
from turbgen.validation.store_run import MannBox

CHI2_95 = Z95**2  # chi^2 quantile 0.95 of one degree of freedom
N_NODES = 48  # k1 nodes of the coherence (interpolated to the record's lines)
N_SCAN = 61  # ln gamma scan points over the range of evo
MOVE_TOL, PASSES = 0.01, 6
VAR_FLOOR = 1e-12  # float32 round-off of stored series: identical records give r = 1 within ~1e-7
POS_TOL_M = 1e-3  # points closer than this in y and z share a (y, z)


@dataclass(frozen=True, eq=False)
class EvoFit:
    """The eddy-evolution time fitted to longitudinal coherence (module docstring).

    Attributes
    ----------
    value_s : float
        gamma [s].
    ci95 : tuple
        (lo, hi) [s]; hi None when the frozen limit is inside the interval.
    chi2, chi2_frozen : float
        chi^2 at gamma and at the frozen limit (Taylor), with the same weights.
    dof : int
        Bands times pairs minus one.
    pairs_m : tuple
        (x_i, x_j) [m] of the fitted pairs: their positions along the wind.
    lateral_m : tuple
        y_j - y_i [m] of each pair: its offset across the wind (0 on a lattice and for masts on the wind's line).
    message : str
        One line: identified or not, and why.
    f_hz : numpy.ndarray
        Band centres [Hz].
    data, fitted, sd : dict
        ((x_i, y_i), (x_j, y_j)) -> (nbands,) co-coherence estimates of the pair of positions [m], their expectation
        at gamma, their standard deviations.
    ci95_held : tuple
        (lo, hi) [s] of the coherence alone, ae, L and Gamma held (None: a range end not reached).
    sensitivity : numpy.ndarray
        d ln gamma / d (ln ae, ln L, Gamma) that carries the one-point fit's covariance into ``ci95``.
    """

    value_s: float
    ci95: tuple
    chi2: float
    chi2_frozen: float
    dof: int
    pairs_m: tuple
    message: str
    f_hz: np.ndarray
    data: dict
    fitted: dict
    sd: dict
    ci95_held: tuple
    sensitivity: np.ndarray
    lateral_m: tuple = ()

    @property
    def identified(self) -> bool:
        return self.ci95[1] is not None

    def to_dict(self) -> dict:
        return {"value": self.value_s, "ci95": list(self.ci95), "held": False, "identified": self.identified,
                "chi2": self.chi2, "chi2_frozen": self.chi2_frozen, "dof": self.dof,
                "pairs_m": [list(p) for p in self.pairs_m], "lateral_m": list(self.lateral_m), "message": self.message}

    def plot(self, ax) -> None:
        """Co-coherence per pair of x with 95 % bars and the fitted model on ``ax``."""
        for k, (a, b) in enumerate(self.data):
            across = f", {b[1] - a[1]:+.3g} m apart in y" if b[1] != a[1] else ""
            ax.errorbar(self.f_hz, self.data[a, b], yerr=1.96 * self.sd[a, b], fmt="o", ms=3, color=f"C{k}",
                        label=f"x = {a[0]:.4g}, {b[0]:.4g} m{across} data")
            ax.plot(self.f_hz, self.fitted[a, b], "-", color=f"C{k}", label=f"fitted, evo = {self.value_s:.3g} s")
        ax.set_xscale("log")
        ax.set_xlabel("f [Hz]")
        ax.set_ylabel("co-coherence along x (u; a lidar's v_los)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)


@dataclass(frozen=True, eq=False)
class Sampler:
    """How sensor-like series (lidar gates) were sampled: ``gain(x_m, k1)``, the power gain |H(k1)|^2 at k1 [rad/m] of
    the points at x [m] (a probe volume; a pair's cross-spectrum is sqrt(g_a g_b) times the points': H real, positive),
    and the Mann store's ``grid`` and ``box`` they were read from (their coherence's lattice; None: continuous)."""

    gain: Callable[[float, np.ndarray], np.ndarray]
    grid: Grid | None = None
    box: MannBox | None = None


def x_pairs(xyz: tuple, lateral: bool = False) -> dict:
    """((x_i, y_i), (x_j, y_j)) with x_j - x_i > POS_TOL_M -> [(column at i, column at j)] of the u columns at one
    (y, z), positions (x, 0); ``lateral``: at one z, positions (x, y) (points across the wind from each other)."""
    groups: dict = {}
    for c, (x, y, z) in enumerate(xyz):
        key = round(z / POS_TOL_M) if lateral else (round(y / POS_TOL_M), round(z / POS_TOL_M))
        groups.setdefault(key, []).append(((x, y if lateral else 0.0), c))
    out: dict = {}
    for cols in groups.values():
        cols.sort()
        for a, (pa, ca) in enumerate(cols):
            for pb, cb in cols[a + 1:]:
                if pb[0] - pa[0] > POS_TOL_M:
                    out.setdefault((pa, pb), []).append((ca, cb))
    return out


def _lag(data: FitData, x_m: float) -> int:  # whole samples of Taylor's delay x / U: sensor columns' shift
    return round(x_m / (data.U_m_s * data.dt_s))


def taylor_rest(data: FitData, x_a: float, x_b: float) -> float:
    """Taylor's delay [s] between columns at ``x_a``, ``x_b`` [m] left by their shifts (0 in a store: convected)."""
    return 0.0 if data.grid is not None else (x_b - x_a) / data.U_m_s - (_lag(data, x_b) - _lag(data, x_a)) * data.dt_s


def _aligned(data: FitData) -> np.ndarray:
    """u of ``data`` in the convected frame: sensor columns shifted by whole samples of x / U (module docstring)."""
    u = data.series["u"]
    if data.grid is not None:
        return u
    lag = np.array([_lag(data, x) for x, _, _ in data.u_xyz_m])
    lag -= lag.min()
    n = u.shape[0] - lag.max()
    return np.stack([u[lag.max() - s: lag.max() - s + n, c] for c, s in enumerate(lag)], axis=1)


class CoherenceModel:
    """Expected band co-coherence of pairs dx apart along the wind (and dy across it) as a function of gamma, the
    other parameters held (module docstring): per k1 node the Phi_11 masses and their decay rates at gamma = 1 s."""

    def __init__(self, bands, data: FitData, params: MannParams, sampler: Sampler | None = None):
        self.bands, self.U, self.sampler, self.data, self.params = bands, data.U_m_s, sampler, data, params
        self._across: dict = {}
        grid, box = (data.grid, data.box) if sampler is None else (sampler.grid, sampler.box)
        band_model = BandModel(bands, data.U_m_s, grid, box, params.lifetime)
        band_model.update_ratio(params)
        self.kernel, self.k1, self.band_model = band_model.kernel, band_model.k1, band_model
        f11 = band_model.line_spectra(params.ae, params.length_scale_m, params.gamma)["uu"]
        self.f11_lines = np.concatenate([[0.0], f11 * band_model.dk1])
        self._gain: dict = {}
        self.nodes = np.geomspace(self.k1[0], self.k1[-1], N_NODES)
        unit = self.unit = replace(params, evo_time_s=1.0)
        self.lattice = not (grid is None or box is None)
        if not self.lattice:
            kappa, w, g = perpendicular_quadrature(self.nodes, params, ((0, 0),))
            self.mass = w * g[(0, 0)]
            self.rate = 1.0 / evolution_lifetime_s(np.sqrt(self.nodes[:, None] ** 2 + kappa**2), unit)
        else:
            slabs = list(MannLattice(unit, cast(Grid, grid), box, data.U_m_s).slabs(self.nodes))
            self.mass = np.stack([phi[0, 0].ravel() for _, phi, _ in slabs])
            self.rate = np.stack([inv_tau.ravel() for _, _, inv_tau in slabs])

    def moved(self, params: MannParams) -> CoherenceModel:
        """The same model for other ae, L, Gamma (``_sensitivity``)."""
        return CoherenceModel(self.bands, self.data, params, self.sampler)

    @staticmethod
    def along_wind(a: tuple, b: tuple) -> bool:
        """Whether the frozen field's co-coherence of positions ``a``, ``b`` is 1 (one y: apart along the wind only)."""
        return a[1] == b[1]

    def gain(self, x_m: float) -> tuple[np.ndarray, np.ndarray]:
        """(nt/2 + 1,) power gain of the points at ``x_m`` [m] at the lines 0 .. nt/2 and their band auto-spectra."""
        if x_m not in self._gain:
            g = np.ones(self.f11_lines.size) if self.sampler is None else np.concatenate(
                [[1.0], self.sampler.gain(x_m, self.k1)])
            self._gain[x_m] = g, self.bands.band_mean(self.kernel.apply(self.f11_lines * g))
        return self._gain[x_m]

    def across(self, dy_m: float) -> tuple[np.ndarray, np.ndarray]:
        """(mass, rate) at the k1 nodes of points ``dy_m`` [m] apart across the wind: the (k2, k3) plane's Phi_11
        exp(i k2 dy) and decay rates at gamma = 1 s (continuous model only; dy = 0: the one-point masses)."""
        if abs(dy_m) <= POS_TOL_M:
            return self.mass, self.rate
        if self.lattice:
            raise ValueError("a lattice's co-coherence is taken at one (y, z)")
        if dy_m not in self._across:
            kappa, w, g = perpendicular_quadrature(self.nodes, self.params, ((0, 0),), dy_m=dy_m)
            rate = 1.0 / evolution_lifetime_s(np.sqrt(self.nodes[:, None] ** 2 + kappa**2), self.unit)
            self._across[dy_m] = np.real(w * g[(0, 0)]), rate
        return self._across[dy_m]

    def expected(self, gamma_s: float, a: tuple, b: tuple) -> np.ndarray:
        """(nbands,) expected co-coherence of points at the positions ``a`` and ``b`` (x, y) [m] (before the
        estimator's bias); gamma_s = inf: the frozen field's."""
        mass, rate = self.across(abs(b[1] - a[1]))
        node = (mass * np.exp(-rate * (abs(b[0] - a[0]) / (self.U * gamma_s)))).sum(1) / self.mass.sum(1)
        x_a, x_b = a[0], b[0]
        turn = np.cos(self.k1 * self.U * taylor_rest(self.data, x_a, x_b))  # 2 pi f delta at the lines
        rho = np.concatenate([[1.0], np.interp(np.log(self.k1), np.log(self.nodes), node) * turn])
        (g_a, auto_a), (g_b, auto_b) = self.gain(x_a), self.gain(x_b)
        return self.bands.band_mean(self.kernel.apply(self.f11_lines * np.sqrt(g_a * g_b) * rho)) / np.sqrt(
            auto_a * auto_b)


def _estimates(data: FitData, nperseg: int, pairs: dict):
    """(bands of the aligned u, (npairs, nbands) co-coherences, (npairs, nbands) variance factors)."""
    u = _aligned(data)
    bands = estimate_bands(replace(data, series={"u": u}, uw_columns=()), min(nperseg, u.shape[0] // 4))
    X, ok = segment_dfts(u, bands.setup)
    r, factor, of_x = [], [], {}
    for (pa, _), cols in pairs.items():
        a, b = (np.array(c) for c in zip(*cols))
        r.append(bands.co_coherence(X, ok, a, b))
        key = (pa, tuple(a))  # the point-correlation sum of the points at one position
        if key not in of_x:
            one = replace(data, series={"u": u[:, a]}, uw_columns=())
            of_x[key] = estimate_bands(one, bands.setup.nperseg).var_factor["uu"] * rho_bar(X[:, :, a], bands.bands)
        factor.append(of_x[key])
    return bands, np.array(r), np.array(factor)


def rho_bar(X: np.ndarray, bands: tuple) -> np.ndarray:
    """(nbands,) rho_bar = sum_ab coh2_ab / P^2 of the P columns of X (K, nf, P): the variance of a P-point average
    of auto-spectrum estimates over that of one point. With G_ss' = sum_a conj(X_sa) X_s'a, E|G_ss'|^2 = sum_ab
    |S_ab|^2 and E[G_ss G_s's'] = (sum_a S_aa)^2 for independent segments (Isserlis 1918): their means over segment
    pairs at least two hops apart (no overlap) give rho_bar without the 1/K bias of a coherence estimate."""
    g = np.einsum("kfa,lfa->fkl", np.conj(X), X)  # (nf, K, K)
    far = np.abs(np.arange(g.shape[1])[:, None] - np.arange(g.shape[1])[None, :]) >= 2
    diag = np.real(np.einsum("fkk->fk", g))
    num = (np.abs(g) ** 2)[:, far].sum(axis=1)
    den = (diag[:, :, None] * diag[:, None, :])[:, far].sum(axis=1)
    return np.array([np.clip(num[b].sum() / den[b].sum(), 1.0 / X.shape[2], 1.0) for b in bands])


class _Problem:
    """chi^2 of the co-coherences against the model, weights at a given gamma."""

    def __init__(self, model: CoherenceModel, seps: tuple, r: np.ndarray, factor: np.ndarray):
        self.model, self.seps, self.r, self.factor = model, seps, r, factor
        self.xs = sorted({x for pair in seps for x in pair})  # the positions (x, y)

    def rho(self, gamma_s: float) -> dict:
        """(a, b) -> (nbands,) expected co-coherence, for every two positions of the pairs (a <= b)."""
        one = np.ones(self.r.shape[1])  # a point with itself
        return {(a, b): one if a == b else self.model.expected(gamma_s, a, b) for a in self.xs for b in self.xs
                if a <= b}

    def frozen(self) -> np.ndarray:
        """(npairs, nbands) co-coherence of the frozen field (Taylor): 1 along the wind, the model's across it."""
        along = [self.model.along_wind(a, b) for a, b in self.seps]
        mean = None if all(along) else self.mean(math.inf)
        return np.array([np.ones(self.r.shape[1]) if on else cast(np.ndarray, mean)[m] for m, on in enumerate(along)])

    def mean(self, gamma_s: float) -> np.ndarray:
        rho = self.rho(gamma_s)
        e = np.array([rho[pair] for pair in self.seps])
        return e - e * (1 - e**2) * self.factor / 4

    def set_weights(self, gamma_s: float) -> None:
        """Cholesky factor of the (band, pair) covariance at ``gamma_s`` (module docstring)."""
        rho = self.rho(gamma_s)
        nx, nb, npair = len(self.xs), self.r.shape[1], len(self.seps)
        cov = np.empty((nb, npair, npair))
        for b in range(nb):
            R = np.array([[rho[min(p, q), max(p, q)][b] for q in self.xs] for p in self.xs])
            M = np.zeros((npair, nx, nx))
            for m, (p, q) in enumerate(self.seps):
                i, j = self.xs.index(p), self.xs.index(q)
                M[m, i, j] = M[m, j, i] = 0.5
                M[m, i, i] = M[m, j, j] = -R[i, j] / 2
            MR = M @ R
            f = np.sqrt(np.outer(self.factor[:, b], self.factor[:, b]))
            cov[b] = np.einsum("mij,nji->mn", MR, MR) * f + VAR_FLOOR * np.eye(npair)
        sd = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
        corr = cov / (sd[:, :, None] * sd[:, None, :])
        pair = 0.5 * (corr[:, None] + corr[None, :])
        full = self.model.bands.band_corr[:, :, None, None] * pair * sd[:, None, :, None] * sd[None, :, None, :]
        self.sd = sd.T  # (npair, nb)
        self.chol = np.linalg.cholesky(full.transpose(0, 2, 1, 3).reshape(nb * npair, nb * npair))

    def chi2(self, ln_gamma: float) -> float:
        res = (self.r - self.mean(math.exp(ln_gamma))).T.ravel()  # band-major, as the covariance
        return float(np.sum(solve_triangular(self.chol, res, lower=True) ** 2))

    def best(self, lo: float, hi: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(ln gamma at the least chi^2, scan points, chi^2 there) over [lo, hi]."""
        grid = np.linspace(lo, hi, N_SCAN)
        c = np.array([self.chi2(x) for x in grid])
        k = int(np.argmin(c))
        a, b = grid[max(k - 1, 0)], grid[min(k + 1, N_SCAN - 1)]
        x = minimize_scalar(self.chi2, bounds=(a, b), method="bounded", options={"xatol": 1e-4}).x
        return (x if self.chi2(x) <= c[k] else grid[k]), grid, c


def fit_evolution(data: FitData, params: MannParams, nperseg: int, fit: MannFit | None = None,
                  sampler: Sampler | None = None) -> EvoFit | str:
    """EvoFit of gamma to the longitudinal coherence of ``data`` (module docstring), or one line saying why not (no two
    u points along x at one (y, z)). ``params``: ae, L, Gamma of the one-point fit (held); ``nperseg`` [samples]: its
    Welch segments; ``fit``: that MannFit, whose uncertainty the interval carries (None: ``params`` exact);
    ``sampler``: how sensor-like series were sampled from a store (``Sampler``; None: ``data``'s own lattice if any)."""
    lateral = data.grid is None and sampler is None  # sensor data: masts may be apart across the wind too
    data = in_wind_frame(data) if lateral else data
    pairs = x_pairs(data.u_xyz_m, lateral) if "u" in data.series else {}
    if not pairs:
        return ("evo_time_s not fitted: the data hold no two u series at one (y, z) and different x (two masts "
                "along the wind or two planes are needed)" if not lateral else "evo_time_s not fitted: the data "
                "hold no two u series at one height and apart along the wind (two masts are needed)")
    return fit_pairs(data, pairs, lambda bands: CoherenceModel(bands, data, params, sampler), nperseg, fit)


def fit_pairs(data: FitData, pairs: dict, model_of: Callable, nperseg: int, fit: MannFit | None = None) -> EvoFit:
    """EvoFit of gamma to the co-coherences of ``pairs`` (as ``x_pairs``: position pairs -> column pairs of u) against
    ``model_of(bands)``: a model with ``bands``, ``params``, ``expected(gamma_s, a, b)``, ``along_wind(a, b)`` and
    ``moved(params)`` (``CoherenceModel``; ``fit_evolution``'s other arguments)."""
    seps = tuple(pairs)
    bands, r, factor = _estimates(data, nperseg, pairs)
    problem = _Problem(model_of(bands), seps, r, factor)
    params = problem.model.params
    evo = ranges.RANGES["evo_time_s"]
    lo, hi = math.log(evo.lo), math.log(evo.hi)
    x = math.log(400.0)
    for _ in range(PASSES):
        problem.set_weights(math.exp(x))
        x_new, grid, c = problem.best(lo, hi)
        moved, x = abs(x_new - x), x_new
        if moved < MOVE_TOL:
            break
    c_min = problem.chi2(x)
    ends = [_profile_end(problem, x, c_min, grid, c, side) for side in (-1, 1)]
    slope, var = np.zeros(3), 0.0
    if fit is not None and fit.cov_fit is not None and all(e is not None for e in ends):
        slope = _sensitivity(problem, params, x, np.diag(fit.cov_fit), (lo, hi))
        var = _propagated(problem, data, fit, pairs, slope, x)
    ci = [None if e is None else x + side * math.sqrt(max((e - x) ** 2 + CHI2_95 * var, 0.0))
          for e, side in zip(ends, (-1, 1))]
    chi2_frozen = float(np.sum(solve_triangular(problem.chol, (r - problem.frozen()).T.ravel(), lower=True) ** 2))
    return _result(problem, bands, x, ci, c_min, chi2_frozen, (lo, hi), (ends, slope))


def _sensitivity(problem: _Problem, params: MannParams, x: float, var: np.ndarray, rng: tuple) -> np.ndarray:
    """d ln gamma / d (ln ae, ln L, Gamma) of the fit: ln gamma refitted (weights held) with ln L, then Gamma, moved
    by one sd of the one-point fit (a secant); 0 for ae (the co-coherence is a ratio: ae cancels) and for a held or
    unidentified parameter. A step that would leave the parameter's range goes the other way, within it."""
    slope = np.zeros(3)
    for k, name in ((1, "length_scale_m"), (2, "gamma")):
        r, at = ranges.RANGES[name], math.log(params.length_scale_m) if k == 1 else params.gamma
        lo, hi = (math.log(r.lo), math.log(r.hi)) if k == 1 else (r.lo, r.hi)
        step = math.sqrt(var[k]) if math.isfinite(var[k]) else 0.0
        step = -min(step, (at - lo) / 2) if at + step > hi else step  # a fit at the top of its range (L 1000 m)
        if step == 0.0:
            continue
        moved = (replace(params, length_scale_m=params.length_scale_m * math.exp(step)) if k == 1
                 else replace(params, gamma=params.gamma + step))
        shifted = _Problem(problem.model.moved(moved), problem.seps, problem.r, problem.factor)
        shifted.chol = problem.chol
        slope[k] = (shifted.best(*rng)[0] - x) / step
    return slope


def _propagated(problem: _Problem, data: FitData, fit: MannFit, pairs: dict, slope: np.ndarray, x: float) -> float:
    """Variance the one-point fit adds to ln gamma: s^T Sigma s + 2 a^T C G^T s, s = ``slope``, Sigma and G the fit's
    covariance and gain (``linear_terms``: a and C)."""
    k, cov = slope != 0, cast(np.ndarray, fit.cov_fit)
    var = float(slope[k] @ cov[np.ix_(k, k)] @ slope[k])
    if fit.gain is None or len(fit.f_hz) != len(problem.model.bands.f_hz):
        return var
    a, cross = linear_terms(problem, data, fit, pairs, x)
    return var + 2.0 * float(a @ cross @ fit.gain.T @ slope)


def linear_terms(problem: _Problem, data: FitData, fit: MannFit, pairs: dict, x: float) -> tuple:
    """(a, C): a = d ln gamma / d r of the coherence fit at ln gamma = ``x`` (band-major), C the covariance of the
    co-coherences with the one-point fit's band spectra (``evo_cross``; rows and columns band-major)."""
    dm = (problem.mean(math.exp(x + 1e-3)) - problem.mean(math.exp(x - 1e-3))) / 2e-3
    w = solve_triangular(problem.chol, dm.T.ravel(), lower=True)
    a = solve_triangular(problem.chol, w, lower=True, trans="T") / (w @ w)
    seps, index, _ = separations(np.asarray(data.sites_m, float))
    g = problem.model.band_model.coherency(replace(fit.params, evo_time_s=math.exp(x)), seps)
    if problem.model.band_model.grid is None:  # frozen between x (``model``): times the co-coherence at dx
        for dx in {abs(d) for d in seps[:, 0] if abs(d) > POS_TOL_M}:
            rho = problem.model.expected(math.exp(x), (0.0, 0.0), (dx, 0.0))
            g[..., np.abs(np.abs(seps[:, 0]) - dx) < POS_TOL_M] *= rho[:, None, None, None]
    cols, used = np.asarray(cast(dict, data.columns)["u"]), tuple(fit.data)
    sites = [tuple(cols[list(c)] for c in zip(*pairs[p])) for p in problem.seps]
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.nan_to_num(coherence_spectra_corr(g, index, sites, point_sets(data, used), used))
    sd_f = np.stack([cast(dict, fit.sd)[s] for s in used])
    return a, cross_covariance(corr, problem.model.bands.band_corr, problem.sd, sd_f)


def _profile_end(problem: _Problem, x: float, c_min: float, grid, c, side: int) -> float | None:
    """ln gamma where chi^2 = c_min + CHI2_95 on ``side`` (-1 below x, +1 above); None: not reached in the range."""
    level = c_min + CHI2_95
    beyond = np.flatnonzero((side * (grid - x) > 0) & (c > level))
    if beyond.size == 0:
        return None
    far = grid[beyond[0] if side > 0 else beyond[-1]]
    return brentq(lambda t: problem.chi2(t) - level, x, far, xtol=1e-4)


def _result(problem: _Problem, bands, x: float, ci: list, c_min: float, chi2_frozen: float, rng, held) -> EvoFit:
    """EvoFit of a finished fit, with the one line saying whether gamma is identified."""
    gamma = math.exp(x)
    lo = math.exp(rng[0]) if ci[0] is None else math.exp(ci[0])
    hi = None if ci[1] is None else math.exp(ci[1])
    dof = problem.r.size - 1
    if hi is None:
        msg = (f"evo_time_s not identified: the frozen (Taylor) limit is inside the 95 % interval (chi2 "
               f"{chi2_frozen:.4g} frozen against {c_min:.4g} at best, dof {dof}); evo_time_s > {lo:.4g} s")
    elif ci[0] is None:
        msg = f"evo_time_s not identified from below: coherence ~ 0 (pairs too far apart); evo_time_s < {hi:.4g} s"
    else:
        msg = (f"evo_time_s identified; the frozen (Taylor) limit is excluded (chi2 {chi2_frozen:.4g} against "
               f"{c_min:.4g}, dof {dof})")
    seps = problem.seps
    ends = tuple(None if e is None else math.exp(e) for e in held[0])
    return EvoFit(gamma, (lo, hi), c_min, chi2_frozen, dof, tuple((float(a[0]), float(b[0])) for a, b in seps), msg,
                  bands.f_hz, dict(zip(seps, problem.r)), dict(zip(seps, problem.mean(gamma))),
                  dict(zip(seps, problem.sd)), ends, held[1], tuple(float(b[1] - a[1]) for a, b in seps))


def with_evolution(data: FitData, fit, sampler: Sampler | None = None):
    """``fit`` (a MannFit of ``data``) with ``evolution`` fitted (``sampler`` as fit_evolution's), or a note why not."""
    evo = fit_evolution(data, fit.params, fit.nperseg, fit, sampler)
    if isinstance(evo, str):
        return replace(fit, notes=fit.notes + (evo,))
    return replace(fit, evolution=evo, notes=fit.notes + (evo.message,))
