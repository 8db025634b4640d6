"""Fit the IEC Kaimal model to data: sigma_k, L_k of the u, v, w spectra and a, Lc of the u coherence.

Spectra: S_k(f) = 4 sigma_k^2 (L_k/U) / (1 + 6 f L_k/U)^(5/3) (IEC 61400-1 Annex C; Guo et al. 2023, Eq. 11). The
expected Welch band estimate gives line j the variance of S_k over its bin [(j - 1/2) df, (j + 1/2) df]
(``kaimal_band_variance``) through the estimator's leakage and mean removal (``WelchKernel``): exactly a turbgen Kaimal
store's discrete spectrum (turbgen.synthesis.kaimal_evo) and, for sensor data, the Mann fit's periodic approximation.

Weights: the Welch covariance of ``spectra`` with the point averages' Isserlis terms (``covariance.isserlis``) from
the model's coherency between points: u's exp(-a r sqrt((f/U)^2 + (0.12/Lc)^2)) (Guo et al. 2023, Eq. 12 un-squared;
r the y-z distance) at the fitted a, Lc; v and w white for a store made so (IEC, TurbSim IECKAI), else u's (for
sensors an assumption). The components are independent, so each one's (ln sigma, ln L) is fitted alone by iteratively
re-weighted generalised least squares (``gls``); 95 % intervals x +- 1.96 sd of (J^T W J)^-1, exponentiated. a and
Lc: ``kaimal_coherence``."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import least_squares

from turbgen.theory import ranges
from turbgen.theory.coherence_models import exponential_yz
from turbgen.theory.kaimal import kaimal_band_variance
from turbgen.theory.lattice import line_bands
from turbgen.validation.fit.covariance import isserlis, separations
from turbgen.validation.fit.data import FitData
from turbgen.validation.fit.mann import MOVE_TOL, Z95, parameter_covariance
from turbgen.validation.fit.result import FitValue
from turbgen.validation.fit.spectra import estimate_bands
from turbgen.validation.welch_kernel import WelchKernel

if TYPE_CHECKING:
    from turbgen.validation.fit.kaimal_result import KaimalFit

IEC_COHERENCE = (12.0, 340.2)  # a [-], Lc = 8.1 Lambda1 [m] (IEC 61400-1, hub above 60 m): the starting weights
START_L_M = 100.0
PASSES = 12  # re-weighting passes: u's weights can make the passes alternate about the answer, closing slowly


def gls(residual, covariance, x0, lo, hi) -> tuple:
    """Iteratively re-weighted generalised least squares: minimise |C^-1/2 residual(x)|^2, C = covariance(x) at the
    previous pass's x, until no parameter moves by MOVE_TOL sd (at most PASSES passes): (scipy solution, (J^T W J)^-1,
    converged)."""
    x, converged = np.clip(np.asarray(x0, float), lo, hi), False
    for _ in range(PASSES):
        chol = np.linalg.cholesky(covariance(x))
        sol = least_squares(lambda y: solve_triangular(chol, residual(y), lower=True), x, bounds=(lo, hi),
                            diff_step=1e-4, xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=200)
        cov = parameter_covariance(sol.jac)
        moved = np.abs(sol.x - x) / np.maximum(np.sqrt(np.abs(np.diag(cov))), 1e-300)
        x = sol.x
        if sol.status > 0 and np.all(moved < MOVE_TOL):
            converged = True
            break
    return sol, cov, converged


def log_values(names: tuple, keys: tuple, sol, cov, lo, hi) -> tuple[dict, list]:
    """name -> FitValue of exp(x) with the 95 % interval exp(x +- 1.96 sd), and flags: on a range boundary, or an
    interval over the whole range (not identified; ``keys``: the ``ranges`` entries of the names)."""
    values, flags = {}, []
    for k, (n, key) in enumerate(zip(names, keys)):
        sd = math.sqrt(abs(cov[k, k]))
        ci = tuple(float(np.exp(np.clip(sol.x[k] + s * Z95 * sd, -700.0, 700.0))) for s in (-1, 1))
        values[n] = FitValue(math.exp(sol.x[k]), ci, sd)
        if sol.active_mask[k] != 0 or min(sol.x[k] - lo[k], hi[k] - sol.x[k]) < 1e-6:
            r = ranges.RANGES[key]
            flags.append(f"{n} = {values[n].value:.4g} is on the boundary of its range [{r.lo:g}, {r.hi:g}]")
        elif ci[0] <= math.exp(lo[k]) and ci[1] >= math.exp(hi[k]):
            flags.append(f"{n} is not identified by the data: its 95 % interval covers its range")
    return values, flags


class KaimalBands:
    """Expected band estimates of ``bands`` for Kaimal spectra (module docstring)."""

    def __init__(self, bands, U_m_s: float):
        self.bands, self.U = bands, U_m_s
        self.edges = line_bands(bands.nt, bands.setup.dt_s)
        self.kernel = WelchKernel(bands.setup, bands.nt)

    def lines(self, sigma_m_s: float, length_m: float) -> np.ndarray:
        """(nt/2 + 1,) variances [m^2 s^-2] of the lines +f_j (``WelchKernel``): half the bin's; line 0 (the mean) 0."""
        v = 0.5 * kaimal_band_variance(*self.edges, sigma_m_s, length_m, self.U)
        v[0] = 0.0
        return v

    def expected(self, lines: np.ndarray) -> np.ndarray:
        """(nbands,) expected one-sided band estimate [m^2 s^-2 Hz^-1] of a line process."""
        return self.bands.band_mean(self.kernel.apply(lines))


def _coherency(data: FitData, f_hz, coherence, white_vw: bool) -> tuple:
    """(nbands, 3, 3, D) coherency between the points (module docstring) and the ``separations`` geometry."""
    seps, index, neg = separations(np.asarray(data.sites_m, float))
    r = np.hypot(seps[:, 1], seps[:, 2])
    coh = np.zeros((len(f_hz), 3, 3, len(seps)), complex)
    g = exponential_yz(r[None, :], np.asarray(f_hz)[:, None], data.U_m_s, *coherence)
    for i in range(3):
        coh[:, i, i] = g if i == 0 or not white_vw else (r == 0)
    return coh, index, neg


def fit_spectrum(model: KaimalBands, c: str, x0, iss) -> tuple:
    """(solution, covariance, converged, lower, upper bounds) of component ``c``'s (ln sigma, ln L) (module docstring;
    ``iss``: the Isserlis terms of its points)."""
    s, b = c + c, model.bands
    ex = lambda x: model.expected(model.lines(math.exp(x[0]), math.exp(x[1])))  # noqa: E731
    r_s, r_l = ranges.RANGES["sigma_m_s"], ranges.RANGES["length_scales_m"]
    lo, hi = np.log([r_s.lo, r_l.lo]), np.log([r_s.hi, r_l.hi])
    return (*gls(lambda x: b.values[s] - ex(x), lambda x: b.full_covariance((s,), {s: ex(x)}, iss), x0, lo, hi),
            lo, hi)


def fit_kaimal_data(data: FitData, nperseg: int | None = None) -> KaimalFit:
    """The KaimalFit of the Kaimal spectra and the u coherence to ``data`` (FitData; of a store with several planes the
    first plane; module docstring); ``nperseg`` [samples] defaults to ``estimators.default_nperseg``. ParameterError
    for a record too short or too gappy for the Welch estimates (``spectra.estimate_bands``)."""
    from turbgen.validation.fit.kaimal_coherence import fit_coherence
    from turbgen.validation.fit.kaimal_result import KaimalFit

    data, notes = _first_plane(data)
    bands = estimate_bands(replace(data, uw_columns=()), nperseg)
    model = KaimalBands(bands, data.U_m_s)
    attrs = data.attrs or {}
    white_vw = attrs.get("model") == "kaimal" and attrs["parameters"].get("vw_coherence") == "white"
    if attrs.get("model") == "kaimal" and attrs["parameters"].get("rescale"):
        notes.append("the store's spectra were rescaled to their nominal sigma over the resolved band: the fitted "
                     "sigma_k are those of the rescaled spectra")

    def component(c, coherence):
        geo = _coherency(data, bands.f_hz, coherence, white_vw)
        iss = isserlis(*geo, {c + c: np.asarray(data.columns[c])}, (c + c,))
        return fit_spectrum(model, c, [math.log(max(float(np.nanstd(data.series[c])), 1e-2)), math.log(START_L_M)],
                            iss)

    fits = {c: component(c, IEC_COHERENCE) for c in "uvw" if c in data.series}
    notes += [f"sigma_{c}, L_{c}: not identified (the data hold no {c})" for c in "uvw" if c not in fits]
    cfit = fit_coherence(data, bands, model, model.lines(*np.exp(fits["u"][0].x))) if "u" in fits else \
        "a_yz, lc_m: not identified (the data hold no u)"
    if not isinstance(cfit, str):  # u's weights at the fitted coherence
        fits["u"] = component("u", (cfit.a.value, cfit.lc_m.value))
    values, flags = {}, []
    for c, (sol, cov, ok, lo, hi) in fits.items():
        v, f = log_values((f"sigma_{c}_m_s", f"length_{c}_m"), ("sigma_m_s", "length_scales_m"), sol, cov, lo, hi)
        values.update(v)
        flags += f + ([] if ok else [f"the {c} spectrum fit did not converge ({sol.message.rstrip('.')})"])
    return KaimalFit.of(data, bands, model, values, fits, cfit, flags, notes)


def _first_plane(data: FitData) -> tuple[FitData, list]:
    """``data`` restricted to the points of a store's first plane (several planes: not independent sensors)."""
    notes = list(data.notes) + ["the Kaimal fit does not apply the sonic paths (path_m)"] * (data.path_m is not None)
    x_m = [] if data.grid is None else data.grid.x_m  # type: ignore[attr-defined]
    if len(x_m) < 2:
        return data, notes
    keep = np.flatnonzero(np.asarray(data.sites_m)[:, 0] == x_m[0])
    notes.append(f"only the plane x = {x_m[0]:g} m is fitted (of {len(x_m)})")
    sites = np.asarray(data.sites_m)[keep]
    return replace(data, series={c: s[:, keep] for c, s in data.series.items()}, sites_m=sites, uw_columns=(),
                   columns={c: np.arange(keep.size) for c in data.series}, u_xyz_m=tuple(map(tuple, sites))), notes
