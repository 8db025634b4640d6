"""Fit ae, L and Gamma of the Mann (1994) model to the Welch spectra of measured or generated data.

Generalised least squares in x = (ln ae, ln L, Gamma) over the band estimates of F_uu, F_vv, F_ww and the u-w
co-spectrum (``spectra``), whitened by their joint covariance at the model (``covariance``): sum r^2 is chi^2 with
n_bands - n_parameters dof; bounded by ``turbgen.theory.ranges``. The weights and a store's lattice / continuous ratio
are updated at the fitted parameters until they move by < MOVE_TOL sd (at most PASSES); within a pass the ratio follows
L and Gamma to first order (``BandModel.update_ratio``; benchmarks/fit.md). cov(x) = (J^T J)^-1; 95 % intervals
x +- 1.96 sd, exponentiated for ae and L. The eddy lifetime (Guo et al. 2023, Eq. 6-7, or Mann 1994, Eq. 4) is a
turbgen store's own, else ``lifetime``. Gamma needs two components' spectra; with one it is held at the default."""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import brentq, least_squares

from turbgen.errors import ParameterError, check_choice
from turbgen.spec.defaults import MANN_DEFAULTS
from turbgen.theory import ranges
from turbgen.theory.params import LIFETIMES, MannParams
from turbgen.validation.estimators import segment_starts
from turbgen.validation.fit.covariance import (EXACT_BINS, exact_lines, isserlis, line_covariance, point_sets,
                                               separations, spliced)
from turbgen.validation.fit.data import FitData, in_wind_frame
from turbgen.validation.fit.model import BandModel
from turbgen.validation.fit.result import FitValue, MannFit, misfit_notes
from turbgen.validation.fit.spectra import SPECTRA, BandSpectra, estimate_bands

Z95 = 1.959963984540054  # standard normal 97.5 % quantile
PASSES = 6
MOVE_TOL = 0.05  # re-weighting stops when no parameter moved by more than this many standard deviations
AE_MIN = 1e-6  # lower end of the fitted ae [m^(4/3) s^-2] (the range's open 0)
NAMES = ("ae", "length_scale_m", "gamma")


def bounds(free: tuple) -> tuple[np.ndarray, np.ndarray]:
    r = ranges.RANGES
    lo = {"ae": math.log(AE_MIN), "length_scale_m": math.log(r["length_scale_m"].lo), "gamma": r["gamma"].lo}
    hi = {"ae": math.log(r["ae"].hi), "length_scale_m": math.log(r["length_scale_m"].hi), "gamma": r["gamma"].hi}
    return np.array([lo[n] for n in free]), np.array([hi[n] for n in free])


def _params(x: np.ndarray, free: tuple, held: dict) -> dict:
    return {**held, **{n: math.exp(v) if n != "gamma" else float(v) for n, v in zip(free, x)}}


def _start(bands: BandSpectra, model: BandModel, used: tuple, held: dict) -> dict:
    """Starting point: L and Gamma at the defaults (or held), ae matching the data's band spectra in the mean."""
    p = {"length_scale_m": MANN_DEFAULTS["length_scale_m"], "gamma": MANN_DEFAULTS["gamma"], **held, "ae": 1.0}
    e = model.expected(p["ae"], p["length_scale_m"], p["gamma"])
    ratios = np.concatenate([bands.values[s] / e[s] for s in used if s != "uw"])
    p["ae"] = float(np.clip(np.median(ratios), 10 * AE_MIN, ranges.RANGES["ae"].hi / 10))
    return p


def data_lifetime(data: FitData, lifetime: str | None = None) -> str:
    """The eddy lifetime to fit ``data`` with: a Mann store's own (ParameterError when ``lifetime`` contradicts it),
    else ``lifetime`` or the default."""
    parameters = (data.attrs or {}).get("parameters", {})
    stored = parameters.get("lifetime")  # a Mann store's
    if parameters.get("factor1", 1.0) != 1.0:
        raise ParameterError(f"{data.source} was generated with factor1 = {parameters['factor1']}: the fit's tables hold "
                             "the lifetime with factor1 = 1 only (Guo et al. 2023, Eq. 7)")
    if stored is not None and lifetime is not None and lifetime != stored:
        raise ParameterError(f"lifetime = {lifetime!r}: {data.source} was generated with lifetime {stored!r}; drop "
                             "the option or give that one")
    return check_choice("lifetime", stored or lifetime or MANN_DEFAULTS["lifetime"], LIFETIMES)


def _covariance_at(bands, model, geometry, used, p) -> np.ndarray:
    """Joint covariance (band-major) of the band estimates at the parameters ``p`` (``covariance``): band centres,
    and the bands within bins 1 .. EXACT_BINS from the record's lines (a sensor's record taken as periodic; not
    with gaps). Lines below a segment's lowest bin are coherent over many segments: the band-centre covariance left
    the first bin's variance ~1.5 x short on a 10-minute sonic record (benchmarks/fit_wetb.md)."""
    seps, index, neg, sets = geometry
    params = MannParams(**p, lifetime=model.lifetime)
    e = model.expected(p["ae"], p["length_scale_m"], p["gamma"])
    full = bands.full_covariance(used, e, isserlis(model.coherency(params, seps), index, neg, sets, used))
    low = [b for b in bands.bands if b[-1] <= EXACT_BINS]
    whole = len(segment_starts(bands.nt, bands.setup))
    if not low or any(bands.segments[s[0]] < whole * sets[s].size for s in used if s != "uw"):
        return full
    cross = model.line_cross(params, seps, exact_lines(bands.nt, bands.setup.nperseg))
    bins = line_covariance(cross, bands.setup, bands.nt, index, sets, used)
    avg = np.zeros((len(low), EXACT_BINS))
    for r, b in enumerate(low):
        avg[r, b - 1] = 1.0 / b.size
    exact = np.einsum("am,mxny,bn->axby", avg, bins, avg).reshape(len(low) * len(used), -1)
    return spliced(full, exact)


def gls(residual, covariance_at, x: np.ndarray, free: tuple, passes: int = PASSES, limits=None):
    """Re-weighted generalised least squares in x (the ``free`` parameters, within ``limits`` = (lo, hi), default
    ``bounds``): per pass ``residual(x)`` (data - model) whitened by the Cholesky factor of ``covariance_at(x)`` is
    minimised, until no parameter moves by MOVE_TOL sd (at most ``passes``). (solution, cov(x) = (J^T J)^-1, the last
    weights, converged)."""
    lo, hi = bounds(free) if limits is None else limits
    for _ in range(passes):
        weights = covariance_at(x)
        chol = np.linalg.cholesky(weights)
        sol = least_squares(lambda y: solve_triangular(chol, residual(y), lower=True), np.clip(x, lo, hi),
                            bounds=(lo, hi), diff_step=1e-4, xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=200)
        cov = parameter_covariance(sol.jac)
        moved, x = np.abs(sol.x - x) / np.maximum(np.sqrt(np.diag(cov)), 1e-300), sol.x
        if sol.status > 0 and np.all(moved < MOVE_TOL):
            return sol, cov, weights, True
    return sol, cov, weights, False


def inverted_interval(stat, x: float, step: float, lo: float, hi: float) -> tuple[float, float]:
    """95 % interval of one fitted variable by inverting a test: the y where ``stat(y)`` (chi^2 with one degree of
    freedom under "the variable is y") rises Z95^2 above ``stat(x)`` at the fit ``x``, bracketed by steps of ``step``
    (about its sd) outwards, then Brent's root; a range end (``lo``, ``hi``) where it does not rise that far."""
    level, step, ends = stat(x) + Z95**2, min(max(step, 1e-3), 1.0), []
    for edge in (lo, hi):
        a = x
        while a != edge:
            b = edge if abs(edge - a) <= step else a + math.copysign(step, edge - a)
            if stat(b) >= level:
                a = brentq(lambda y: stat(y) - level, a, b, xtol=1e-6)
                break
            a = b
        ends.append(a)
    return ends[0], ends[1]


def fit_mann_data(data: FitData, nperseg: int | None = None, bands: BandSpectra | None = None,
                  lifetime: str | None = None) -> MannFit:
    """Fit the Mann model to ``data`` (FitData, module docstring): a MannFit with values, 95 % intervals, chi^2 / dof,
    flags, the band spectra and the fitted model. ``nperseg`` [samples] defaults to ``estimators.default_nperseg``;
    ``bands`` replaces the band estimates of ``data`` (synthetic spectra with known noise: the tests); ``lifetime``
    as in ``data_lifetime``. ParameterError for a record too short or too gappy for the Welch estimates, or a
    ``lifetime`` other than a store's own."""
    lifetime, data = data_lifetime(data, lifetime), in_wind_frame(data)
    bands = estimate_bands(data, nperseg) if bands is None else bands
    model = BandModel(bands, data.U_m_s, data.grid, data.box, lifetime, data.spectrum_paths())
    used = tuple(s for s in SPECTRA if s in bands.values)
    notes = list(data.notes) + ([f"sonic path averaging applied (paths {sorted(set(data.path_m.tolist()))} m; u, v, "
                                 "w along x, y, z)"] if model.transfer else [])
    held = {}
    if sum(s != "uw" for s in used) < 2:
        held["gamma"] = MANN_DEFAULTS["gamma"]
        notes.append(f"gamma is not identified by the spectrum of one component ({used[0][0]}): held at "
                     f"{held['gamma']:g}")
    free = tuple(n for n in NAMES if n not in held)
    geometry = (*separations(np.asarray(data.sites_m, float)), point_sets(data, used))
    p = _start(bands, model, used, held)

    def residual(x):
        e = model.expected(**_params(x, free, held))
        return np.stack([bands.values[s] - e[s] for s in used], axis=1).ravel()  # band-major

    def weights_at(x, ratio=True):  # the grid ratio at x (not in the continuous pre-fit), the weights at x
        q = _params(x, free, held)
        if ratio:
            model.update_ratio(MannParams(**q, lifetime=lifetime), slopes=True)
        return _covariance_at(bands, model, geometry, used, q)

    x = np.array([p[n] if n == "gamma" else math.log(p[n]) for n in free])
    if model.kind == "grid":  # the continuous fit first: the lattice ratio at a point near the answer
        x = gls(residual, lambda y: weights_at(y, ratio=False), x, free, passes=1)[0].x
    sol, cov, weights, converged = gls(residual, weights_at, x, free)
    p = _params(sol.x, free, held)
    return _result(data, bands, model, used, free, held, p, sol, cov, converged, notes, weights)


def parameter_covariance(jac: np.ndarray) -> np.ndarray:
    """(J^T J)^-1 of the whitened residuals; infinite variances where J^T J is singular (unidentified)."""
    jtj = jac.T @ jac
    try:
        cov = np.linalg.inv(jtj)
    except np.linalg.LinAlgError:
        return np.full(jtj.shape, np.inf)
    return np.where(np.isfinite(cov), cov, np.inf)


def _result(data, bands, model, used, free, held, p, sol, cov, converged, notes, weights) -> MannFit:
    """The MannFit of a finished fit: intervals, chi^2 / dof, flags."""
    sd = np.sqrt(np.abs(np.diag(cov)))
    values, flags = {}, []
    lo, hi = bounds(free)
    for k, n in enumerate(free):
        a, b = sol.x[k] - Z95 * sd[k], sol.x[k] + Z95 * sd[k]
        ci = (a, b) if n == "gamma" else (math.exp(a) if math.isfinite(a) else 0.0, math.exp(b))
        values[n] = FitValue(p[n], (float(ci[0]), float(ci[1])), float(sd[k]))
        if sol.active_mask[k] != 0 or min(sol.x[k] - lo[k], hi[k] - sol.x[k]) < 1e-6:
            r = ranges.RANGES[n]
            flags.append(f"{n} = {p[n]:.4g} is on the boundary of its range [{r.lo:g}, {r.hi:g}]")
    for n, v in held.items():
        values[n] = FitValue(v, None, None)
    if not converged:
        flags.append(f"the fit did not converge ({sol.message.rstrip('.')}; {PASSES} re-weighting passes)")
    dof = int(sol.fun.size - len(free))
    e = model.expected(p["ae"], p["length_scale_m"], p["gamma"])
    seg_m = bands.setup.nperseg * bands.setup.dt_s * data.U_m_s
    if seg_m < 2 * math.pi * p["length_scale_m"]:
        notes.append(f"the Welch segments ({seg_m:.4g} m of flow) are shorter than 2 pi L = "
                     f"{2 * math.pi * p['length_scale_m']:.4g} m: the spectral peak is below the lowest band")
    chi2_dof = float(np.sum(sol.fun**2) / max(dof, 1))
    notes += misfit_notes(chi2_dof, dof)
    rows, ok = [NAMES.index(n) for n in free], bool(np.all(np.isfinite(cov)))
    full, gain = np.zeros((len(NAMES), len(NAMES))), np.zeros((len(NAMES), sol.fun.size))
    full[np.ix_(rows, rows)] = cov
    if ok:  # else a parameter is unidentified (infinite variance): gain None
        gain[rows] = -cov @ solve_triangular(np.linalg.cholesky(weights), sol.jac, lower=True, trans="T").T
    return MannFit(
        ae=values["ae"], length_scale_m=values["length_scale_m"], gamma=values["gamma"],
        chi2_dof=chi2_dof, dof=dof, flags=tuple(flags), notes=tuple(notes),
        model=model.kind, lifetime=model.lifetime, U_m_s=data.U_m_s, source=data.source,
        nperseg=bands.setup.nperseg, f_hz=bands.f_hz,
        data={s: bands.values[s] for s in used}, fitted={s: e[s] for s in used},
        sd=dict(zip(used, np.sqrt(np.diag(weights)).reshape(-1, len(used)).T)), cov_fit=full,
        gain=gain if ok else None,
    )  # fmt: skip
