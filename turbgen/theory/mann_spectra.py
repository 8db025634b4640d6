"""One-point spectra, cross-spectra, coherences and variances of the Mann tensor (Guo et al. 2023, Eq. 8-10).

k1 in rad/m, finite (k1 = 0 is the limit k1 -> 0); spectra are TWO-SIDED in k1 [m^3 s^-2]:
sigma_i^2 = ∫_{-inf}^{inf} F_ii dk1, and the one-sided frequency spectrum is S_i(f) = 2 F_ii(k1) 2 pi / U.
The (k2, k3) quadrature of Eq. 8 is turbgen.theory.mann_quadrature. Components i, j are 0, 1, 2
(u, v, w); anything else, or a k1 or separation that is not finite, raises ParameterError."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from turbgen.errors import ParameterError, check_positive
from turbgen.theory.mann_quadrature import N_GAUSS, check_k1, gauss, perpendicular_quadrature
from turbgen.theory.params import MannParams

COMPONENTS = {"F11": (0, 0), "F22": (1, 1), "F33": (2, 2), "F12": (0, 1), "F13": (0, 2), "F23": (1, 2)}


def _integrate(weights, values):
    return (weights * values).sum(axis=-1)


def one_point_spectra(k1, params: MannParams) -> dict[str, np.ndarray]:
    """Two-sided one-point spectra at k1 (Guo et al. 2023, Eq. 8 with dy = dz = 0).

    Parameters
    ----------
    k1, params : array_like, MannParams
        Longitudinal wavenumbers [rad/m] and Mann model.

    Returns
    -------
    dict of str to numpy.ndarray
        "F11", "F22", "F33", "F12", "F13", "F23", each (len(k1),) [m^3 s^-2].
    """
    k1 = check_k1(k1)
    _, w, g = perpendicular_quadrature(k1, params, tuple(COMPONENTS.values()))
    return {name: _integrate(w, g[p]) for name, p in COMPONENTS.items()}


def cross_spectrum(k1, params: MannParams, i: int, j: int, dy_m: float = 0.0, dz_m: float = 0.0) -> np.ndarray:
    """Complex two-sided cross-spectrum F_ij(k1, dy, dz) [m^3 s^-2], (len(k1),) (Guo et al. 2023, Eq. 8).

    Parameters
    ----------
    k1, params : array_like, MannParams
        Longitudinal wavenumbers [rad/m] and Mann model.
    i, j, dy_m, dz_m : int, int, float, float
        Velocity components; lateral and vertical separation [m] (optional).
    """
    for name, v in (("i", i), ("j", j)):
        if v not in (0, 1, 2):
            raise ParameterError(f"component {name} = {v!r} must be 0, 1 or 2")
    _, w, g = perpendicular_quadrature(k1, params, ((i, j),), dy_m, dz_m)
    return _integrate(w, g[(i, j)]).astype(complex)


def yz_coherence(k1, params: MannParams, i: int, j: int, dy_m: float, dz_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Magnitude-squared coherence (Eq. 9) and un-squared co-coherence (Eq. 10) of Guo et al. (2023).

    ``coh2 = |F_ij|^2 / (F_ii F_jj)``, ``cocoh = Re F_ij / sqrt(F_ii F_jj)``, each (len(k1),) [-]; arguments as
    :func:`cross_spectrum`."""
    k1 = check_k1(k1)
    fij = cross_spectrum(k1, params, i, j, dy_m, dz_m)
    _, w, g = perpendicular_quadrature(k1, params, ((i, i), (j, j)))
    fii, fjj = _integrate(w, g[(i, i)]), _integrate(w, g[(j, j)])
    return np.abs(fij) ** 2 / (fii * fjj), fij.real / np.sqrt(fii * fjj)


@lru_cache(maxsize=64)
def _k1_rule(length_scale_m: float):
    """Nodes and weights of ∫_0^K dk1 in Gauss panels of ln(k1 L) on [1e-6, 1e5]/L, and K."""
    gx, gw = gauss(N_GAUSS)
    edges = np.linspace(np.log(1e-6), np.log(1e5), 27)
    t = edges[:-1, None] + np.diff(edges)[:, None] * gx[None, :]
    k = np.exp(t).ravel() / length_scale_m
    w = (np.diff(edges)[:, None] * gw[None, :]).ravel() * k
    return k, w, 1e5 / length_scale_m


def _one_point(params: MannParams) -> MannParams:
    """``params`` without what one-point statistics never read (evolution: evo_time_s, factor2), for the cache key."""
    return MannParams(params.ae, params.length_scale_m, params.gamma, params.lifetime, params.factor1, evo_time_s=None)


@lru_cache(maxsize=256)
def _variances_cached(params: MannParams, names: tuple[str, ...] = ("F11", "F22", "F33", "F13")) -> tuple[float, ...]:
    """The integrals of ``names`` only: each spectrum's quadrature is independent of the others (same bits)."""
    k, w, k_max = _k1_rule(params.length_scale_m)
    _, wq, g = perpendicular_quadrature(np.append(k, k_max), params, tuple(COMPONENTS[n] for n in names))
    out = []
    for name in names:
        f = _integrate(wq, g[COMPONENTS[name]])
        body = np.sum(w * f[:-1])
        tail = 1.5 * k_max * f[-1]  # ∫_K^inf C k^(-5/3) dk with C = F(K) K^(5/3); F13 decays faster
        out.append(2.0 * (body + (tail if name != "F13" else 0.0)))  # two-sided: both signs of k1
    return tuple(out)


def variances(params: MannParams) -> dict[str, float]:
    """sigma_u^2, sigma_v^2, sigma_w^2 and <uw> = ∫ F_ij dk1 [m^2 s^-2] (keys uu vv ww uw), cached per ``params``
    less its evolution (frozen and evolving fields share them).

    Gauss panels in ln(k1 L) on [1e-6, 1e5] plus the inertial tail (3/2) K F(K) beyond K = 1e5/L; at
    Gamma = 0 they match (1/3) B(5/2, 1/3) ae L^(2/3) to 1e-6."""
    uu, vv, ww, uw = _variances_cached(_one_point(params))
    return {"uu": uu, "vv": vv, "ww": ww, "uw": uw}


def ae_for_sigma_u(sigma_u_m_s: float, params: MannParams) -> float:
    """alpha*eps^(2/3) [m^(4/3) s^-2] that gives ``sigma_u_m_s`` [m/s] for the shape (L, Gamma, lifetime) of ``params``.

    Spectra are linear in ae, so ae = sigma_u^2 / sigma_u^2(ae = 1). Raises ParameterError for sigma_u <= 0."""
    sigma = check_positive("sigma_u (m/s)", sigma_u_m_s)
    (unit,) = _variances_cached(_one_point(params.with_ae(1.0)), ("F11",))  # spectra are linear in ae; sigma_u^2 alone
    return sigma * sigma / unit
