"""The IEC u coherence fitted to data: a and Lc of g(r, f) = exp(-a r sqrt((f/U)^2 + (0.12/Lc)^2)).

Estimate: the co-coherence (real part: the IEC coherency has no phase) of u points at one x a y-z distance r apart,
pooled over the pairs at that distance, their Welch segments (``spectra``) and the band's bins:
r_m = sum Re X_i* X_j / sqrt(sum |X_i|^2 sum |X_j|^2). Model: rho_m = sum K(v_j g(r_m, f_j)) / sum K(v_j) over the
band (K the Welch kernel, v_j the fitted u lines; Guo et al. 2023, Eq. 12 un-squared): exact for a turbgen Kaimal store.

Variance: the delta method with the Isserlis (1918) moments of complex Gaussian DFTs: r_m = rho_m + the pair-mean of
Z_ij = Re X_i* X_j - rho_m (|X_i|^2 + |X_j|^2) / 2 (unit spectra), so Cov(r_m, r_n) = tr(M_m R M_n R) c, M_m the
pair-mean of Z's symmetric matrices, R the points' coherencies, c the one-point band factor of ``spectra``; one pair
gives (1 - rho^2)^2 c / 2 (Bendat & Piersol 2010, Sect. 9.2.3). The bias to the same order, rho var / (2 (1 - rho^2)),
is subtracted. Bands covary through the bins (``covariance.joined``). (ln a, ln Lc) by ``kaimal.gls``; a's interval
from its covariance, Lc's from the chi^2 profile (``_lc_profile``)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import brentq, minimize_scalar

from turbgen.theory import ranges
from turbgen.theory.coherence_models import exponential_yz
from turbgen.theory.lattice import line_frequencies
from turbgen.validation.fit.covariance import joined
from turbgen.validation.fit.kaimal import IEC_COHERENCE, gls, log_values
from turbgen.validation.fit.result import FitValue
from turbgen.validation.fit.spectra import segment_dfts

POS_TOL_M = 1e-3  # points closer than this share an x / a distance
A_MIN = 1e-2  # lower end of the fitted a [-] (the range's 0: full coherence)
VAR_FLOOR = 1e-12  # float32 round-off of identical records
CHI2_95 = 3.841458820694124  # chi^2 quantile 0.95 of one degree of freedom
PROFILE_STEP = 0.5  # ln Lc step of the profile's search for its ends


@dataclass(frozen=True, eq=False)
class CoherenceFit:
    """a [-] and Lc [m] with 95 % intervals (Lc's end None: not identified, ``note`` says so); chi^2 / dof; per
    distance r_m the band estimates, fit and sd."""

    a: FitValue
    lc_m: FitValue
    chi2_dof: float
    dof: int
    flags: tuple
    r_m: tuple
    data: np.ndarray
    fitted: np.ndarray
    sd: np.ndarray
    note: str | None = None


def distance_classes(xyz) -> dict:
    """y-z distance r [m] -> [(i, j)] pairs of the columns ``xyz`` (x, y, z) at one x, r > 0."""
    p, out = np.asarray(xyz, float), dict[float, list]()
    for i, j in combinations(range(len(p)), 2):
        r = math.hypot(*(p[i, 1:] - p[j, 1:]))
        if abs(p[i, 0] - p[j, 0]) < POS_TOL_M and r > POS_TOL_M:
            out.setdefault(round(r, 3), []).append((i, j))
    return dict(sorted(out.items()))


class _Problem:
    def __init__(self, data, bands, model, lines, classes):
        u, self.bands, self.model, self.lines, self.U = data.series["u"], bands, model, lines, data.U_m_s
        self.r = np.array(list(classes))
        p = np.asarray(data.sites_m, float)[np.asarray(data.columns["u"])]
        self.dist = np.hypot(p[:, None, 1] - p[None, :, 1], p[:, None, 2] - p[None, :, 2])
        self.f = line_frequencies(bands.nt, bands.setup.dt_s)
        self.auto = model.expected(lines)
        X, ok = segment_dfts(u, bands.setup)
        P, est = u.shape[1], []
        self.A, self.D = np.zeros((len(classes), P, P)), np.zeros((len(classes), P, P))
        for m, pairs in enumerate(classes.values()):
            a, b = (np.array(c) for c in zip(*pairs))
            est.append(bands.co_coherence(X, ok, a, b))
            for M, (i, j) in ((self.A, (a, b)), (self.A, (b, a)), (self.D, (a, a)), (self.D, (b, b))):
                np.add.at(M[m], (i, j), 0.5 / a.size)
        self.est = np.array(est).T  # (nb, D)
        self.var = np.zeros_like(self.est)

    def rho(self, x, r) -> np.ndarray:
        """(nb, len(r)) expected band co-coherence at distances ``r`` for x = (ln a, ln Lc)."""
        g = exponential_yz(np.asarray(r)[:, None], self.f[None, :], self.U, math.exp(x[0]), math.exp(x[1]))
        return np.array([self.model.expected(self.lines * gi) for gi in g]).T / self.auto[:, None]

    def mean(self, x) -> np.ndarray:
        rho = self.rho(x, self.r)
        return rho - rho * self.var / (2 * np.maximum(1 - rho**2, 1e-9))

    def covariance(self, x) -> np.ndarray:
        d, inverse = np.unique(np.round(self.dist, 3), return_inverse=True)
        rho_all, rho = self.rho(x, d), self.rho(x, self.r)
        cov = np.empty((self.est.shape[0], self.r.size, self.r.size))
        for b in range(cov.shape[0]):
            R = rho_all[b][inverse.reshape(self.dist.shape)]
            MR = (self.A - rho[b][:, None, None] * self.D) @ R
            cov[b] = np.einsum("mij,nji->mn", MR, MR) * self.bands.var_factor["uu"][b] + VAR_FLOOR * np.eye(self.r.size)
        self.var = np.diagonal(cov, axis1=1, axis2=2).copy()
        return joined(cov, self.bands.band_corr)


def fit_coherence(data, bands, model, lines) -> CoherenceFit | str:
    """a and Lc fitted to the u co-coherence of ``data`` (module docstring), or one line saying why not; ``bands``,
    ``model``: the Welch bands and ``kaimal.KaimalBands`` of the one-point fit; ``lines``: its u lines."""
    if "u" not in data.series:
        return "a_yz, lc_m: not identified (the data hold no u)"
    classes = distance_classes(np.asarray(data.sites_m, float)[np.asarray(data.columns["u"])])
    if not classes:
        return ("a_yz, lc_m: not identified (a single u sensor: two or more at one x, apart in y or z, give the "
                "coherence)")
    prob = _Problem(data, bands, model, lines, classes)
    r_a, r_l = ranges.RANGES["a_yz"], ranges.RANGES["lc_m"]
    lo, hi = np.log([A_MIN, r_l.lo]), np.log([r_a.hi, r_l.hi])
    sol, cov, converged = gls(lambda x: (prob.est - prob.mean(x)).ravel(), prob.covariance, np.log(IEC_COHERENCE),
                              lo, hi)
    values, flags = log_values(("a_yz", "lc_m"), ("a_yz", "lc_m"), sol, cov, lo, hi)
    flags = [f for f in flags if not f.startswith("lc_m")]
    values["lc_m"], note = _lc_profile(prob, sol.x, values["lc_m"].sd_fit, lo, hi)
    if not converged:
        flags.append(f"the coherence fit did not converge ({sol.message.rstrip('.')})")
    dof = int(sol.fun.size - 2)
    return CoherenceFit(values["a_yz"], values["lc_m"], float(np.sum(sol.fun**2) / max(dof, 1)), dof, tuple(flags),
                        tuple(map(float, prob.r)), prob.est.T, prob.mean(sol.x).T, np.sqrt(prob.var).T, note)


def _lc_profile(prob: _Problem, x: np.ndarray, sd: float, lo, hi) -> tuple[FitValue, str | None]:
    """Lc with the profile interval where chi^2 (a re-fitted) <= min + 3.84 (ln Lc is far from Gaussian: the data
    see Lc only through the lowest bands), an end None where the range's end is inside; and a note then."""
    chol = np.linalg.cholesky(prob.covariance(x))

    def chi2(ln_lc: float) -> float:
        res = lambda t: float(np.sum(solve_triangular(chol, (prob.est - prob.mean([t, ln_lc])).ravel(),  # noqa: E731
                                                      lower=True) ** 2))
        return minimize_scalar(res, bounds=(x[0] - 3, x[0] + 3), method="bounded", options={"xatol": 1e-4}).fun

    level, ends = chi2(x[1]) + CHI2_95, []
    for side, bound in ((-1, lo[1]), (1, hi[1])):
        t, end = x[1], None
        while side * (bound - t) > 1e-9:
            step = t + side * min(PROFILE_STEP, side * (bound - t))
            if chi2(step) > level:
                end = math.exp(brentq(lambda u: chi2(u) - level, t, step, xtol=1e-3))
                break
            t = step
        ends.append(end)
    note = None
    if ends == [None, None]:
        note = "lc_m not identified: its 95 % interval covers its range"
    elif None in ends:
        bound = f"lc_m > {ends[0]:.4g} m" if ends[1] is None else f"lc_m < {ends[1]:.4g} m"
        note = (f"lc_m not identified from {'above' if ends[1] is None else 'below'}: the coherence of the lowest "
                f"bands does not fix it; {bound}")
    return FitValue(math.exp(x[1]), tuple(ends), sd), note
