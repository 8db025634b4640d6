"""What a Kaimal / IEC store's model predicts for every estimate, on the store's grid.

Line j of the one-sided Kaimal PSD S_i has the two-sided variance L_j = (1/2) int S_i over [f_j - df/2, f_j + df/2]
(Guo et al. 2023, Eq. 11; the Nyquist line its half bin), L_0 = 0, times sigma_i^2 / sum(2 L_j) if rescaled (a
user spectrum: (1/2) S_j times the band's width). The u yz line cross-covariance is L_j coh(r, f_j) (Eq. 12
un-squared, or a user coherence table); v, w white or the same; between planes the store's longitudinal model
(Eq. 18 / Simley and Pao / Kristensen, un-squared, zero phase) for the components it was applied to. The
rotor-effective wind speed follows Eq. 25 over the rotor points of the grid."""

from __future__ import annotations

import math

import numpy as np

from turbgen.theory.coherence_models import LONGITUDINAL_MODELS, exponential_yz
from turbgen.theory.kaimal import kaimal_band_variance, kaimal_spectrum
from turbgen.theory.lattice import line_frequencies, pair_weights
from turbgen.validation.estimators import COMPONENTS
from turbgen.validation.pair_sums import RhoAccumulator, coherency_matrix, lag_radius, rotor_pair_counts
from turbgen.validation.prediction import SamplingDesign, Theory, plane_separations
from turbgen.validation.store_run import kaimal_model_from_attrs
from turbgen.validation.variance_law import MAX_MODE_POINTS, N_MODE_LINES, top_modes


def kaimal_theory(attrs: dict, design: SamplingDesign) -> Theory:
    """Kaimal / IEC expectations (line (cross-)variances [m^2 s^-2], correlation sums [-]) from the store
    attributes ``attrs`` (``parameters``, ``U_m_s`` [m/s]) for the estimates' sampling ``design``."""
    km = kaimal_model_from_attrs(attrs)
    kp, long_components = km.kaimal, km.long_components
    grid = design.grid
    U = float(attrs["U_m_s"])
    yz_coh, long_fn = _coherences(km, U)
    line_f = line_frequencies(grid.nt, grid.dt_s)
    auto = _auto_lines(km, grid, line_f, U)
    seps = design.separations
    yz = {c: {(a, b): auto[c] * yz_coh(c, math.hypot(a * grid.dy_m, b * grid.dz_m), line_f) for a, b in seps}
          for c in COMPONENTS}  # fmt: skip
    long = {dx: auto["u"] * long_fn(dx, line_f) for dx in plane_separations(grid)}
    # Eq. 25: S_RR = S_1 / n_R^2 sum_ij coh(r_ij, f), summed over the rotor pairs per lag
    counts = rotor_pair_counts(grid, design.rotor_mask)
    radius = lag_radius(grid)
    sel = counts > 0
    rews_factor = np.array([np.sum(counts[sel] * yz_coh("u", radius[sel], f)) for f in line_f])
    rews = auto["u"] * rews_factor / design.rotor_mask.sum() ** 2
    node_f = design.node_freqs()
    acc, rho_rews = _node_correlations(design, node_f, yz_coh, long_fn, long_components)
    modes = _kaimal_modes(km, grid, line_f, yz_coh, long_fn)

    def reference() -> dict:  # continuous Kaimal spectra, or the user's band means (plots only)
        return {f"spectrum_{c}": (line_f[1:], kaimal_spectrum(line_f[1:], kp.sigma_m_s[i], kp.length_scales_m[i], U)
                                  if km.spectrum is None else np.asarray(km.spectrum.S_m2_s[i]))
                for i, c in enumerate(COMPONENTS)}  # fmt: skip

    band = design.band(U)
    band["note"] = (
        f"Kaimal lines f_j = j/(nt dt) up to the Nyquist frequency {band['f_max_hz']:g} Hz; "
        + ("spectra rescaled to the nominal sigma (store attribute rescale)" if km.rescale
           else "the user spectra recorded in the store (band means)" if km.spectrum is not None
           else "variance = the Kaimal integral over the resolved band (no rescaling)")
    )  # fmt: skip
    sigma = kp.sigma_m_s if km.spectrum is None else [math.sqrt(np.sum(pair_weights(grid.nt) * auto[c]))
                                                      for c in COMPONENTS]  # the user spectra's resolved band
    return Theory(
        model="kaimal", nt=grid.nt, line_f=line_f, auto=auto, yz=yz, long=long, rews=rews, node_f=node_f,
        rho_all=acc.all, rho_yz=acc.yz, rho_long=acc.long, rho_rews=rho_rews,
        sigma_model=dict(zip(COMPONENTS, sigma)), band=band, long_components=long_components,
        uw=np.zeros(line_f.size), rho_uw=np.zeros(node_f.size),  # u and w are synthesised independently
        reference=reference, variance_modes=modes,
    )  # fmt: skip


def _coherences(km, U: float):
    """(yz_coh(component, r [m], f [Hz]), long_fn(dx [m], f [Hz])): the run's lateral coherency (Eq. 12, un-squared;
    v and w incoherent unless ``vw_coherence`` is "exp") and its longitudinal coherency model."""
    kp, long_model = km.kaimal, km.long_model
    if long_model == "exp":
        long_fn = lambda dx, f: LONGITUDINAL_MODELS["exp"](dx, f, U, km.a_x, km.b_x)  # noqa: E731
    else:
        s_tot = math.sqrt(sum(s * s for s in kp.sigma_m_s))
        long_fn = lambda dx, f: LONGITUDINAL_MODELS[long_model](dx, f, U, s_tot, kp.length_scales_m[0])  # noqa: E731

    def yz_coh(c, r_m, f):
        if (c == "u" or km.vw_coherence == "exp") and km.coherence is not None:  # the store's table
            return km.coherence(r_m, f)
        if c == "u" or km.vw_coherence == "exp":
            return exponential_yz(r_m, f, U, kp.a_yz, kp.lc_m)  # Eq. 12, un-squared
        return np.where(np.asarray(r_m) == 0, 1.0, 0.0) * np.ones_like(f)

    return yz_coh, long_fn


def _auto_lines(km, grid, line_f: np.ndarray, U: float) -> dict:
    """Component -> the variance [m^2 s^-2] of each record line of the Kaimal spectrum (rescaled if the run was) or
    of the store's user spectra."""
    kp, nt = km.kaimal, grid.nt
    if km.spectrum is not None:  # the generator's band variances, shared by the +-f_j pair
        return {c: v / pair_weights(nt) for c, v in zip(COMPONENTS, km.spectrum.line_variances())}
    df = line_f[1]
    auto = {}
    lo = np.maximum(line_f - df / 2.0, 0.0)
    hi = np.minimum(line_f + df / 2.0, 0.5 / grid.dt_s)
    for i, c in enumerate(COMPONENTS):
        # Eq. 11 integrated over each line's bin [f_j - df/2, f_j + df/2] (clipped at the Nyquist frequency),
        # shared by the +-f_j pair (pair weight 2; the single Nyquist line keeps its bin)
        lines = kaimal_band_variance(lo, hi, kp.sigma_m_s[i], kp.length_scales_m[i], U) / pair_weights(nt)
        lines[0] = 0.0
        if km.rescale:
            lines *= kp.sigma_m_s[i] ** 2 / np.sum(pair_weights(nt) * lines)
        auto[c] = lines
    return auto


def _node_correlations(design: SamplingDesign, node_f: np.ndarray, yz_coh, long_fn, long_components):
    """(RhoAccumulator of the coherencies at all lags, rho_bar of the planes' REWS series (nodes x nodes))."""
    grid = design.grid
    acc = RhoAccumulator(design, node_f.size)
    lag_r = lag_radius(grid)
    for c in COMPONENTS:
        coh_yz = np.stack([yz_coh(c, lag_r, np.full(lag_r.shape, f)) for f in node_f])
        for dx, mult in plane_separations(grid).items():
            if dx == 0:
                acc.add(c, coh_yz, mult, same_plane=True)
            elif c in long_components:
                acc.add(c, coh_yz * long_fn(dx, node_f)[:, None, None], mult, same_plane=False)
    rho_rews = np.zeros((node_f.size, node_f.size))  # planes' REWS series: coherency gamma_x between planes
    for dx, mult in plane_separations(grid).items():
        g_x = long_fn(dx, node_f) if dx > 0 else np.ones(node_f.size)
        rho_rews += mult * np.outer(g_x, g_x) / grid.nx**2
    return acc, rho_rews


def _kaimal_modes(km, grid, line_f: np.ndarray, yz_coh, long_fn) -> dict:
    """Top modes of the lowest lines' coherency matrices (variance law); v, w white: all modes equal, none needed."""
    modes = {}
    if grid.nx * grid.ny * grid.nz > MAX_MODE_POINTS:
        return modes
    lag_r = lag_radius(grid)
    for c in COMPONENTS if km.vw_coherence == "exp" else ("u",):
        def lags(dx, f, c=c):
            g_x = 1.0 if dx == 0 else long_fn(dx, f) if c in km.long_components else 0.0
            return yz_coh(c, lag_r, np.full(lag_r.shape, f)) * g_x

        modes[c] = np.array([top_modes(coherency_matrix({dx: lags(dx, f) for dx in plane_separations(grid)}, grid))
                             for f in line_f[1 : N_MODE_LINES + 1]])  # fmt: skip
    return modes
