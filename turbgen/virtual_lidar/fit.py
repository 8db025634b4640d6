"""Fit the Mann (1994) model to a ``turbgen lidar --out`` dataset: ``turbgen fit mann LIDAR``.

ae and L are fitted to the Welch spectrum of v_los pooled over every beam and gate against the gates' mean LOS spectrum
F(k1) = ∫ n_i n_j Phi_ij |phi_hat(k . n)|^2 dk2 dk3 (Guo et al. 2023, Eq. 29-30): on the box of the Mann store the
dataset was sampled from while it is there, each probe point read as the sampler reads it (``sampled_gain``), else
continuous, (k2, k3) integrated out to TAIL times the highest k1 the probe passes. Gamma is held: the LOS spectrum
is nearly u's. Generalised least squares in (ln ae, ln L), re-weighted at the fitted model, by the bands' exact
covariance from one point's lines times the gates' point correlation (benchmarks/fit_lidar.md); L's interval inverts
the Wald test with the sd at each L. F is tabulated in ln L (step DLN_L) at N_K1 nodes, interpolated cubic. The
evolution time is fitted to the co-coherence of gates at different ranges of a beam along x (Guo et al. 2022),
against a model made as the spectra's (``_with_gates``), else of one inclined beam (``fit_gates``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.linalg import solve_triangular

from turbgen import fft
from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.spec.defaults import MANN_DEFAULTS
from turbgen.theory import ranges
from turbgen.theory.lattice import line_frequencies
from turbgen.theory.lidar_geometry import Measurements
from turbgen.theory.lidar_lattice import BoxLattice, lattice_tensor, lattice_wavenumbers
from turbgen.theory.lidar_preview import KAPPA_MAX, mann_preview_spectra
from turbgen.theory.lidar_weighting import discrete_transform
from turbgen.theory.params import MannParams
from turbgen.validation.estimators import segment_starts
from turbgen.validation.fit.data import FitData, detrended
from turbgen.validation.fit.evolution import Sampler, rho_bar, with_evolution
from turbgen.validation.fit.mann import AE_MIN, PASSES, Z95, bounds, gls, inverted_interval, parameter_covariance
from turbgen.validation.fit.result import FitValue, MannFit, misfit_notes
from turbgen.validation.fit.spectra import estimate_bands, segment_dfts
from turbgen.validation.fit.table import scaled_spectra
from turbgen.validation.store_run import MannBox, mann_box_from_attrs
from turbgen.validation.welch_kernel import WelchKernel
from turbgen.virtual_lidar.dataset import LidarData, is_lidar_dataset, read_dataset
from turbgen.virtual_lidar.description import LidarDescription
from turbgen.virtual_lidar.sampling import interp_axis

N_K1 = 40  # k1 nodes of the LOS spectra (log-spaced over the record's lines)
DLN_L = 0.25  # step of the length-scale grid in ln L
ALONG_X = 1e-9  # a beam with n1 > 1 - ALONG_X looks along x
TAIL = 30.0  # kappa_max / k1_max of the continuous (k2, k3) quadrature
GAIN_MIN = 0.01  # bands where the probe volume passes less power than this are not fitted (``_passed``)
MIN_BANDS = 4
NAMES = ("ae", "length_scale_m")


@dataclass(frozen=True, eq=False)
class SampledStore:
    """The Mann store a dataset was sampled from: its periodic ``box`` (also as the validator's ``mann_box``), ``grid``
    and, per beam, the distinct scan times T modulo dt [s] (where the sampler's linear interpolation in time falls)."""

    box: BoxLattice
    phases_s: tuple
    grid: Grid
    mann_box: MannBox


def probe_gain(k1: np.ndarray, meas, U_m_s: float, store: SampledStore | None) -> np.ndarray:
    """|H(k1)|^2 of one measurement along x: its probe weights, sum_s w_s exp(i k1 s) (Guo et al. 2023, Eq. 30), or
    with ``store`` each point as the sampler reads it, linear in stored time T + x/U between samples
    (``_cell_transfer`` at w dt, w = k1 U), averaged over the scans' phases."""
    s, w = meas.offsets_m[0], meas.weights[0]
    if store is None:
        return discrete_transform(k1, s, w) ** 2
    g, phases = store.grid, store.phases_s[int(meas.beam[0])]
    gain = np.zeros(k1.size)
    for t0 in phases:
        _, at = interp_axis(0.0, g.dt_s, g.nt, t0 + (meas.focus_m[0, 0] + s) / U_m_s)
        gain += np.abs((w * np.exp(1j * k1[:, None] * s) * _cell_transfer(k1[:, None] * U_m_s * g.dt_s, at)).sum(
            axis=1)) ** 2
    return gain / len(phases)


def _cell_transfer(kh: np.ndarray, frac: np.ndarray) -> np.ndarray:
    """Transfer of linear interpolation at a fraction ``frac`` of a cell, kh = wavenumber x cell width: a mode read
    between its nodes, (1 - a) exp(-i kh a) + a exp(i kh (1 - a)), relative to the mode at the point."""
    return (1 - frac) * np.exp(-1j * kh * frac) + frac * np.exp(1j * kh * (1 - frac))


def sampled_amplitudes(k1: np.ndarray, meas, U_m_s: float, store: SampledStore) -> np.ndarray:
    """(phases, k1.size, nyp nzp) complex amplitude A(k) on the box's lattice of one measurement (``meas`` of one row)
    as the sampler reads it, one row per scan phase of its beam: A = sum_s w_s exp(i (-k1 x_s + k2 y_s + k3 z_s)) H_t
    H_y H_z over its probe points p_s, H the transfers of the linear interpolation in stored time T + x_s / U and
    bilinear in (y, z) between the box's nodes (``_cell_transfer``; ``sampling.los_operator`` reads the same cells).
    The tensor's k1 runs along the wind and x upstream, so the store holds mode k as exp(i (-k1 U t + k2 y + k3 z));
    a probe point s along the beam's direction d has the phase -s k . n of the LOS vector n = (d_x, -d_y, -d_z), so
    without H |A|^2 is phi_hat(k . n)^2, the preview theory's (Guo et al. 2023, Eq. 30); with it an inclined beam's
    spectrum is the store's. Two gates of a beam read at one scan time covary as A_a conj(A_b) (relative phase
    included)."""
    g, live = store.grid, meas.weights[0] > 0
    p, w = meas.sample_points_m()[0][live], meas.weights[0][live]
    k2, k3 = lattice_wavenumbers(store.box)
    _, ay = interp_axis(float(g.y()[0]), g.dy_m, g.ny, p[:, 1])
    _, az = interp_axis(float(g.z()[0]), g.dz_m, g.nz, p[:, 2])
    space = w * np.exp(1j * (np.outer(k2, p[:, 1]) + np.outer(k3, p[:, 2])))  # (nodes, K)
    space *= _cell_transfer(k2[:, None] * g.dy_m, ay) * _cell_transfer(k3[:, None] * g.dz_m, az)
    out = []
    for t0 in store.phases_s[int(meas.beam[0])]:
        _, at = interp_axis(0.0, g.dt_s, g.nt, t0 + p[:, 0] / U_m_s)
        along = np.exp(-1j * np.outer(k1, p[:, 0])) * _cell_transfer(-k1[:, None] * U_m_s * g.dt_s, at)
        out.append(along @ space.T)
    return np.stack(out)


def sampled_gain(k1: np.ndarray, meas, U_m_s: float, store: SampledStore) -> np.ndarray:
    """(k1.size, nyp nzp) |A(k)|^2 of one measurement as the sampler reads it (``sampled_amplitudes``), averaged over
    its beam's scan phases: for a beam along x the sign of k1 against (k2, k3) is immaterial (``probe_gain``)."""
    return np.mean(np.abs(sampled_amplitudes(k1, meas, U_m_s, store)) ** 2, axis=0)


def _sampled_los(k1: np.ndarray, terms: list, params: MannParams, U_m_s: float, store: SampledStore) -> np.ndarray:
    """sum over ``terms`` (n, weight, gain) of weight x F(k1) [m^3 s^-2] on the box's lattice, F = sum_k n . Phi(k) n
    |A(k)|^2 (``sampled_gain``): the lattice's tensor once per k1 for every measurement."""
    out = np.zeros(k1.size)
    for q, k in enumerate(k1):
        phi = lattice_tensor(store.box, float(k), params, U_m_s)
        out[q] = sum(w * (np.einsum("i,ijk,j->k", n, phi, n) @ g[q]) for n, w, g in terms)
    return out


def los_spectrum(k1: np.ndarray, meas, params: MannParams, U_m_s: float, store: SampledStore | None) -> np.ndarray:
    """Two-sided spectrum F(k1) [m^3 s^-2] of one measurement's v_los (``meas`` of one row) at k1 > 0 [rad/m]: as
    sampled from ``store`` (``sampled_gain``), else of the continuous tensor."""
    if store is not None:
        return _sampled_los(k1, [(meas.n[0], 1.0, sampled_gain(k1, meas, U_m_s, store))], params, U_m_s, store)
    if meas.n[0, 0] <= 1 - ALONG_X:
        return _quadrature(k1, meas, params, U_m_s)
    L = params.length_scale_m  # phi_hat(k . n) = phi_hat(k1): u's spectrum filtered
    return params.ae * L ** (5 / 3) * scaled_spectra(k1 * L, params.gamma)["uu"] * probe_gain(k1, meas, U_m_s, None)


def _quadrature(k1, meas, params, U_m_s) -> np.ndarray:
    """F(k1) of one measurement by the preview's (k2, k3) quadrature (module docstring)."""
    passed = k1[discrete_transform(k1 * meas.n[0, 0], meas.offsets_m[0], meas.weights[0]) ** 2 >= GAIN_MIN]
    kappa_max = max(KAPPA_MAX, TAIL * float(passed.max(initial=k1[0])))
    s = mann_preview_spectra(k1 * U_m_s / (2 * np.pi), meas, params, U_m_s, 1.0, kappa_max=kappa_max)
    return meas.n[0, 0] ** 2 * s.S_LL * U_m_s / (4 * np.pi)  # S_LL: v_los / n1, one-sided in f


class LosModel:
    """Expected band estimates of the pooled v_los spectrum for (ae, L) at a held Gamma (module docstring)."""

    def __init__(self, bands, U_m_s: float, meas, gamma: float, store: SampledStore | None):
        self.bands, self.U, self.gamma, self.store = bands, U_m_s, gamma, store
        k1 = 2 * np.pi * line_frequencies(bands.nt, bands.setup.dt_s)[1:] / U_m_s
        self.ln_k1, self.dk1 = np.log(k1), 2 * np.pi / (bands.nt * bands.setup.dt_s * U_m_s)
        self.nodes = np.geomspace(k1[0], k1[-1], N_K1)
        self.kernel = WelchKernel(bands.setup, bands.nt)
        own = store is not None  # sampled: each gate its own phases and cells
        key = np.hstack([meas.n, meas.offsets_m, meas.weights, meas.focus_m * own, meas.beam[:, None] * own]).round(12)
        _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
        self.classes = [(meas.subset([i]), c / meas.count) for i, c in zip(first, counts)]
        self.gains = [None if store is None else sampled_gain(self.nodes, m, U_m_s, store) for m, _ in self.classes]
        self.table: dict = {}  # index j of ln L = j DLN_L -> ln F at the nodes (ae = 1)

    def _ln_f(self, j: int) -> np.ndarray:
        """ln of the measurements' mean LOS spectrum F(k1) [m^3 s^-2] at the nodes for L = exp(j DLN_L), ae = 1."""
        if j not in self.table:
            p = MannParams(1.0, math.exp(j * DLN_L), self.gamma)
            if self.store is None:
                f = sum(w * los_spectrum(self.nodes, m, p, self.U, None) for m, w in self.classes)
            else:
                f = _sampled_los(self.nodes, [(m.n[0], w, g) for (m, w), g in zip(self.classes, self.gains)], p, self.U,
                                 self.store)
            self.table[j] = np.log(f)
        return self.table[j]

    def lines(self, ae: float, length_scale_m: float) -> np.ndarray:
        """(nt/2,) variances F(k1_q) dk1 [m^2 s^-2] of the record's lines q = 1 .. nt/2: the table interpolated."""
        t = math.log(length_scale_m) / DLN_L
        j = math.floor(t)
        s = t - j  # Lagrange cubic through nodes j-1 .. j+2
        w = (-s * (s - 1) * (s - 2) / 6, (s + 1) * (s - 1) * (s - 2) / 2, -(s + 1) * s * (s - 2) / 2,
             (s + 1) * s * (s - 1) / 6)
        ln_f = sum(wk * self._ln_f(j - 1 + k) for k, wk in enumerate(w))
        return ae * np.exp(CubicSpline(np.log(self.nodes), ln_f)(self.ln_k1)) * self.dk1

    def expected(self, ae: float, length_scale_m: float) -> np.ndarray:
        """(nbands,) expected pooled band estimate [m^2 s^-2 Hz^-1]: the Welch kernel applied to the lines."""
        return self.bands.band_mean(self.kernel.apply(np.concatenate([[0.0], self.lines(ae, length_scale_m)])))

    def covariance(self, ae: float, length_scale_m: float, rho: np.ndarray, keep: np.ndarray) -> np.ndarray:
        """Covariance of the ``keep`` band estimates pooled over gates of point correlation ``rho`` (``rho_bar``): one
        point's, exact for a periodic record (Isserlis 1918 over the segment pairs, as ``covariance.line_covariance``),
        times sqrt(rho_b rho_c). X_m(s) = sum_t v_m(t) x(s + t) (v: Hann window, DFT row and mean removal), so with the
        autocovariance R of the lines E X_m(s) conj X_n(s') = sum_t' conj v_n(t') c_m(s - s' - t'), c_m = v_m * R."""
        setup, nt, bands = self.bands.setup, self.bands.nt, [b for b, k in zip(self.bands.bands, keep) if k]
        top, n = max(b[-1] for b in bands), setup.nperseg
        v = setup.window * np.exp(-2j * np.pi * np.outer(np.arange(1, top + 1), np.arange(n)) / n)  # (top, n)
        v -= v.sum(axis=1, keepdims=True) / n  # the segment mean removed before the window
        tf = fft.oneshot()
        r = tf.irfft(np.concatenate([[0.0], self.lines(ae, length_scale_m)]), n=nt) * nt  # R(d), d = 0 .. nt - 1
        c = tf.ifft(tf.ifft(v, n=nt) * tf.fft(r), axis=1) * nt  # c_m(d) = sum_t v_m(t) R(d + t)
        starts = np.asarray(segment_starts(nt, setup))
        lag, count = np.unique(starts[:, None] - starts[None, :], return_counts=True)
        cov = sum(k * (np.abs(g @ np.conj(v).T) ** 2 + np.abs(g @ v.T) ** 2)  # |E X_m conj X_n|^2 + |E X_m X_n|^2
                  for k, g in ((k, c[:, (d - np.arange(n)) % nt]) for d, k in zip(lag, count)))
        avg = np.array([np.isin(np.arange(1, top + 1), b) / b.size for b in bands]) * setup.scale[1 : top + 1]
        return avg @ cov @ avg.T * np.sqrt(np.outer(rho[keep], rho[keep])) / starts.size**2


def lidar_fit_data(ld: LidarData, gamma: float | None = None) -> tuple[FitData, Measurements, float]:
    """(FitData of the dataset's detrended v_los, column per beam x gate at its focus, the Measurements, Gamma);
    ParameterError for a dataset whose beams are not sampled uniformly or a Gamma outside its range."""
    meas = LidarDescription(**ld.lidar).measurement_points()
    ns, nb, ng = ld.v_los.shape
    steps = np.diff(ld.time_s, axis=0)
    dt = float(steps.mean()) if ns > 1 else 0.0
    if ns < 2 or np.any(np.abs(steps - dt) > 1e-6 * dt):
        raise ParameterError(f"lidar dataset {ld.source}: {ns} scan(s), not uniformly sampled; the Welch spectra "
                             "need one scan interval")
    cols, notes = detrended(ld.v_los.reshape(ns, nb * ng), lambda k: f"beam {k // ng} gate {k % ng}")
    gaps = int(np.isnan(cols).sum())
    notes += [f"{gaps} missing v_los values (Welch segments holding them are skipped)"] if gaps else []
    g = ranges.check("gamma", MANN_DEFAULTS["gamma"] if gamma is None else gamma, "gamma (Gamma, -)")
    notes.append(f"gamma (Gamma) is not identified by line-of-sight spectra (they are nearly u's): held at {g:g}")
    fd = FitData(ld.source, dt, ld.U_m_s, {"u": cols}, (), notes=tuple(notes), sites_m=meas.focus_m,
                 columns={"u": np.arange(nb * ng)})
    return fd, meas, g


def sampled_store(ld: LidarData) -> SampledStore | None:
    """The Mann store the record was sampled from (``SampledStore``; a dataset names it, a report's record is its
    own), None if it is gone, in memory or not Mann's."""
    import zarr

    from turbgen.store import open_store

    path = zarr.open_group(ld.source, mode="r").attrs.get("source_store") if is_lidar_dataset(ld.source) else ld.source
    if not isinstance(path, str) or not Path(path).is_dir():
        return None
    fs = open_store(path)
    try:
        g, b = fs.grid, mann_box_from_attrs(fs.attrs, fs.grid)
    except ParameterError:  # no Mann parameters: not a Mann store
        return None
    phases = tuple(np.unique(np.round(t % g.dt_s, 9)) for t in ld.time_s.T)
    return SampledStore(BoxLattice(b.nyp, b.nzp, g.dy_m, g.dz_m, g.nt * g.dt_s), phases, g, b)


def fit_lidar(data, nperseg: int | None = None, gamma: float | None = None, store="source") -> MannFit:
    """ae, L (Gamma held) fitted to the LOS spectra of a lidar record (``data``: the path of a lidar dataset, or a
    LidarData), and the evolution time to its gates along x. ``nperseg`` [scans] as in
    ``estimators.default_nperseg``; ``gamma`` [-] held (default MANN_DEFAULTS); ``store``: the SampledStore whose box
    and sampling the spectra follow, "source" (the one sampled, if there) or None (continuous). ParameterError for a
    record not uniformly sampled, too short or too gappy, a bad ``gamma``."""
    ld = data if isinstance(data, LidarData) else read_dataset(data)
    fd, meas, g = lidar_fit_data(ld, gamma)
    store = sampled_store(ld) if store == "source" else store
    bands = estimate_bands(fd, nperseg)
    model = LosModel(bands, fd.U_m_s, meas, g, store)
    keep = _passed(bands, model)
    rho, data = rho_bar(segment_dfts(fd.series["u"], bands.setup)[0], bands.bands), bands.values["uu"][keep]
    rho *= len(segment_starts(bands.nt, bands.setup)) * fd.series["u"].shape[1] / bands.segments["u"]  # gaps: ~1 / K
    x = np.array([math.log(np.median(data / model.expected(1.0, 30.0)[keep])), math.log(30.0)])
    lo, hi = bounds(NAMES)
    lo[1], hi[1] = DLN_L * (math.ceil(lo[1] / DLN_L) + 1), DLN_L * (math.floor(hi[1] / DLN_L) - 2)  # nodes in range
    sol, cov, weights, converged = gls(lambda y: data - model.expected(*np.exp(y))[keep], lambda y: model.covariance(
        math.exp(y[0]), math.exp(y[1]), rho, keep), x, NAMES, passes=3 * PASSES, limits=(lo, hi))  # L oscillates
    x = sol.x
    flags = [] if converged else [f"the fit did not converge ({sol.message.rstrip('.')}; {3 * PASSES} passes)"]
    flags += [f"{n} = {math.exp(v):.4g} is on the boundary of its fitted range [{math.exp(a):.4g}, {math.exp(b):.4g}]"
              for n, v, a, b in zip(NAMES, x, lo, hi) if min(v - a, b - v) < 1e-6]
    sdx = np.sqrt(np.diag(cov))
    ci = [(x[0] - Z95 * sdx[0], x[0] + Z95 * sdx[0]),
          _interval_ln_l(model, data, weights, keep, x, rho, (lo, hi), sdx[1])]
    val = [FitValue(math.exp(v), (math.exp(a), math.exp(b)), float(s)) for v, (a, b), s in zip(x, ci, sdx)]
    full = np.pad(cov, ((0, 1), (0, 1)))  # Gamma held
    e = model.expected(*np.exp(x))[keep]
    notes = fd.notes + (_model_note(store),) + (() if ci[1][1] < hi[1] else (
        f"length_scale_m is not bounded from above by these data: its interval reaches {math.exp(ci[1][1]):.4g} m, the "
        "top of the fitted range",)) + (() if keep.all() else (
        f"bands above {bands.f_hz[keep][-1]:.3g} Hz are not fitted: there the probe volume passes < {GAIN_MIN:g} of "
        "the power, and the spectrum is the probe's and the sampler's rather than the turbulence's",))
    dof = int(sol.fun.size - 2)
    chi2_dof = float(np.sum(sol.fun**2) / max(dof, 1))
    notes += tuple(misfit_notes(chi2_dof, dof, "this line-of-sight spectrum"))
    fit = MannFit(val[0], val[1], FitValue(g, None, None), chi2_dof, dof, tuple(flags), notes,
                  "continuous" if store is None else "grid", fd.U_m_s,
                  fd.source, bands.setup.nperseg, bands.f_hz[keep], {"los": data}, {"los": e},
                  {"los": np.sqrt(np.diag(weights))}, cov_fit=full)  # fmt: skip
    return _with_gates(fd, meas, fit, store)


def _interval_ln_l(model: LosModel, data, weights, keep, x, rho, limits, sd_fit: float) -> tuple[float, float]:
    """95 % interval of ln L within the fit's ``limits`` (lo, hi)[:, 1]: the ln L whose Wald test |ln L^ - ln L| <=
    Z95 sd(ln L) accepts, sd from the GLS covariance at that L (ae at its profile: the model is linear in ae; weights
    and Jacobian there). At L^ (x +- Z95 sd(L^)) it was short on one side: sd ln L grows with L (the peak leaves the
    fitted bands), so a low L^ came with a narrow interval (benchmarks/fit_lidar.md). ``sd_fit`` (the fit's sd of ln L
    at L^) sets the bracketing step."""
    chol = np.linalg.cholesky(weights)
    d = solve_triangular(chol, data, lower=True)

    def sd(y: float) -> float:
        m = [model.expected(1.0, math.exp(y + h))[keep] for h in (0.0, -1e-3, 1e-3)]
        b = solve_triangular(chol, m[0], lower=True)
        ae = max(d @ b / (b @ b), AE_MIN)
        c = np.linalg.cholesky(model.covariance(ae, math.exp(y), rho, keep))
        jac = solve_triangular(c, np.stack([ae * m[0], ae * (m[2] - m[1]) / 2e-3], axis=1), lower=True)
        return float(np.sqrt(parameter_covariance(jac)[1, 1]))

    y0, end = float(x[1]), (float(limits[0][1]), float(limits[1][1]))
    return inverted_interval(lambda y: ((y - y0) / sd(y)) ** 2, y0, float(sd_fit), *end)


def _passed(bands, model: LosModel) -> np.ndarray:
    """Bands whose centre k1 the probe volumes pass with power gain >= GAIN_MIN (phi_hat(k1 n1), Guo et al. 2023,
    Eq. 30); ParameterError for fewer than MIN_BANDS."""
    k1 = 2 * np.pi * bands.f_hz / model.U
    gain = sum(w * discrete_transform(k1 * m.n[0, 0], m.offsets_m[0], m.weights[0]) ** 2 for m, w in model.classes)
    keep = gain >= GAIN_MIN
    if keep.sum() < MIN_BANDS:
        raise ParameterError(f"{bands.nt} scans of {bands.setup.dt_s:g} s give {int(keep.sum())} Welch bands below the "
                             f"probe volume's cut-off (power gain {GAIN_MIN:g}); at least {MIN_BANDS} are needed: a "
                             "longer record or a smaller nperseg")
    return keep


def _model_note(store) -> str:
    if store is None:
        return "line-of-sight spectra of the continuous Mann tensor with the probe volume (Guo et al. 2023, Eq. 29)"
    return (f"line-of-sight spectra summed over the sampled store's {store.box.nyp} x {store.box.nzp} box with the "
            "probe volume as sampled (what the box holds, read linearly in time and bilinearly across as the sampler "
            "reads it)")


def _with_gates(fd: FitData, meas, fit: MannFit, store: SampledStore | None) -> MannFit:
    """``fit`` with the evolution time from the gates of beams along x (else of one inclined beam: ``fit_gates``), or
    a note saying why there is none. As the spectra, their coherence is summed over the sampled ``store``'s lattice
    (the continuous plane holds short-lived large-|k| eddies the box lacks) and weighted by the probe's gain within
    each band (it passes the more coherent low k1 of a band): without either gamma came out high
    (benchmarks/fit_lidar.md)."""
    along = np.flatnonzero(meas.n[:, 0] > 1 - ALONG_X)
    if np.unique(np.round(meas.focus_m[along, 0], 6)).size < 2:
        from turbgen.virtual_lidar.fit_gates import with_inclined_gates  # it builds on this module

        return with_inclined_gates(fd, meas, fit, store)
    gates = replace(fd, series={"u": fd.series["u"][:, along]}, columns={"u": np.arange(along.size)},
                    sites_m=meas.focus_m[along], u_xyz_m=tuple(map(tuple, meas.focus_m[along])))

    def gain(x_m: float, k1: np.ndarray) -> np.ndarray:  # the gates at x_m, averaged
        at = [int(i) for i in along if meas.focus_m[i, 0] == x_m]
        return np.mean([probe_gain(k1, meas.subset([i]), fd.U_m_s, store) for i in at], axis=0)

    lattice = (None, None) if store is None else (store.grid, store.mann_box)
    return with_evolution(gates, fit, Sampler(gain, *lattice))
