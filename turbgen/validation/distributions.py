"""Exact null distributions of the sample coherence and phase (tails the delta method gets wrong).

Setting (Goodman 1963; Carter, Knapp & Nuttall 1973): n independent pairs (x_i, y_i) of circular complex Gaussian
amplitudes with unit variances and complex coherency rho (gamma2 = |rho|^2); sample coherency
C = sum conj(x) y / sqrt(sum|x|^2 sum|y|^2), magnitude-squared coherence g = |C|^2, phase arg C.

Write y = beta x + e with |beta|^2 = gamma2, e ~ CN(0, 1 - gamma2). Conditional on Q = 2 sum|x|^2 ~ chi2_{2n}
(exact for integer n, extended to a real equivalent number of samples):

    (n - 1) g / (1 - g) | Q  ~  F'(2, 2(n - 1); lambda = gamma2 Q / (1 - gamma2))   (noncentral F)
    arg C - arg rho | Q      ~  Rice phase law with kappa = gamma2 Q / (2 (1 - gamma2)).

The unconditional laws average over Q with Gauss-Hermite nodes in the normal score of Q (sampling the extreme
quantiles that drive 1e-6 tails); tails become normal scores (:func:`normal_score`) for ``verdict``."""

from __future__ import annotations

import numpy as np
from scipy.special import (erfc, erfcx, gammainc, gammaincc, gammainccinv, gammaincinv, ncfdtr, ndtr, roots_hermitenorm,
                           roots_laguerre, roots_legendre)
from scipy.stats import norm


N_Q_NODES = 40  # Gauss-Hermite nodes of the chi2_{2n} mixture (normal scores up to ~+-8.9)
N_PHI_NODES = 48  # Gauss-Legendre nodes per piece of the phase tail integral
N_MOMENT_NODES = 40  # Gauss-Laguerre nodes of the coherence moments (relative error < 1e-9 for n >= 1.5)
N_BISECT = 32  # bisection steps of coh2_quantile (24 sd / 2^32)

_s, _w = roots_hermitenorm(N_Q_NODES)
_Q_SCORES, _Q_WEIGHTS = _s, _w / np.sqrt(2.0 * np.pi)
_GL_X, _GL_W = roots_legendre(N_PHI_NODES)
_LAG_X, _LAG_W = roots_laguerre(N_MOMENT_NODES)


def _gamma_nodes(n):
    """Gamma(n) quantiles (halved chi2_{2n} ones) at the Gauss-Hermite normal scores, shape n.shape + (N_Q_NODES,);
    each tail from its own side for precision."""
    n, s = np.asarray(n, float)[..., None], _Q_SCORES
    return np.where(s < 0, gammaincinv(n, ndtr(np.minimum(s, 0.0))), gammainccinv(n, ndtr(-np.maximum(s, 0.0))))


def coh2_tails(g, gamma2, n):
    """(P(G <= g), P(G >= g)) of the sample magnitude-squared coherence G for the observed ``g`` [-] in [0, 1), the
    true ``gamma2`` [-] in [0, 1) and ``n`` (> 1, real) equivalent independent samples; arrays broadcast."""
    g, gamma2, n = np.broadcast_arrays(*(np.asarray(a, float) for a in (g, gamma2, n)))
    g = np.clip(g, 0.0, 1.0 - 1e-15)
    F = ((n - 1.0) * g / (1.0 - g))[..., None]
    lam = (gamma2 / (1.0 - gamma2))[..., None] * (2.0 * _gamma_nodes(n))
    d2 = 2.0 * (n - 1.0)[..., None]
    cdf = ncfdtr(2.0, d2, lam, F)  # noncentral F cdf (Boost); its complement keeps ~1e-10 relative at 1e-6 tails
    # Boost returns nan where the cdf underflows (F far in a tail, e.g. cdf < 1e-200 at lambda ~ 3000): 0 or 1
    # by the side of the law's mean d2 (2 + lambda) / (2 (d2 - 2)) F is on (in practice always the lower tail)
    with np.errstate(divide="ignore", invalid="ignore"):
        side = F > d2 * (2.0 + lam) / (2.0 * (d2 - 2.0))
    cdf = np.where(np.isnan(cdf), np.where(side & (d2 > 2.0), 1.0, 0.0), cdf)
    lower = np.sum(_Q_WEIGHTS * cdf, axis=-1)
    upper = np.sum(_Q_WEIGHTS * (1.0 - cdf), axis=-1)
    return np.clip(lower, 0.0, 1.0), np.clip(upper, 0.0, 1.0)


def coh2_moments(gamma2, n):
    """(E G, sd G) [-] of the sample magnitude-squared coherence (arguments as :func:`coh2_tails`).

    G is a mixture of Beta(1 + j, n - 1) laws with j negative binomial (Carter, Knapp & Nuttall 1973), so
    E[1 - G] = (n - 1) E1 and E[(1 - G)^2] = n (n - 1) (E1 - E2), E1 = E[1 / (n + j)], E2 = E[1 / (n + j + 1)]. With
    u = (1 - gamma2) t / (1 - gamma2 t) in the generating function,

        E1 = (1 - gamma2) int_0^1 u^(n-1) / d(u) du,   E1 - E2 = (1 - gamma2)^2 int_0^1 u^(n-1) (1 - u) / d(u)^2 du,

    d(u) = 1 - gamma2 + gamma2 u; u = exp(-v / n) makes both smooth Gauss-Laguerre integrals (1e-9 relative for n in
    [1.5, 1000], gamma2 in [0, 0.999])."""
    gamma2, n = np.broadcast_arrays(*(np.asarray(a, float) for a in (gamma2, n)))
    c, nn = gamma2[..., None], n[..., None]
    u = np.exp(-_LAG_X / nn)
    d = 1.0 - c + c * u
    e1 = (1.0 - gamma2) / n * np.sum(_LAG_W / d, axis=-1)
    e12 = (1.0 - gamma2) ** 2 / n * np.sum(_LAG_W * (1.0 - u) / d**2, axis=-1)
    h1 = (n - 1.0) * e1
    return 1.0 - h1, np.sqrt(np.maximum(n * (n - 1.0) * e12 - h1**2, 0.0))


def coh2_quantile(p, gamma2, n):
    """Quantile g [-] with P(G <= g) = ``p`` (bisection of :func:`coh2_tails` from mean +- 12 sd); arrays broadcast."""
    p, gamma2, n = np.broadcast_arrays(*(np.asarray(a, float) for a in (p, gamma2, n)))
    mean, sd = coh2_moments(gamma2, n)
    lo, hi = np.maximum(mean - 12.0 * sd, 0.0), np.minimum(mean + 12.0 * sd, 1.0)
    for _ in range(N_BISECT):
        mid = (lo + hi) / 2.0
        below = coh2_tails(mid, gamma2, n)[0] < p
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return (lo + hi) / 2.0


def _rice_phase_pdf(phi, kappa):
    """Density of arg(a + e) on (-pi, pi], a > 0, e ~ CN(0, s2), kappa = a^2 / s2 (Rice phase law)."""
    c, s = np.cos(phi), np.sin(phi)
    x = np.sqrt(kappa) * c
    # sqrt(kappa) c / (2 sqrt(pi)) exp(-kappa s^2) (1 + erf(x)), written without overflow/cancellation
    tail = np.where(x >= 0, np.exp(-kappa * s * s) * (2.0 - erfc(x)), np.exp(-kappa) * erfcx(-np.minimum(x, 0.0)))
    return np.maximum(np.exp(-kappa) / (2.0 * np.pi) + x / (2.0 * np.sqrt(np.pi)) * tail, 0.0)


def _rice_phase_sf(t, kappa):
    """P(|arg(a + e)| >= t), t in [0, pi]: twice the density's integral over [t, pi], in two Gauss-Legendre pieces (the
    first a few standard deviations 1/sqrt(2 kappa) wide, where the tail mass sits)."""
    t = np.asarray(t, float)
    width = np.minimum(np.pi - t, 10.0 / np.sqrt(2.0 * np.maximum(kappa, 1e-12)))
    total = 0.0
    for a, b in ((t, t + width), (t + width, np.full_like(t + width, np.pi))):
        half = (b - a) / 2.0
        phi = (a + b)[..., None] / 2.0 + half[..., None] * _GL_X
        total = total + half * np.sum(_GL_W * _rice_phase_pdf(phi, kappa[..., None]), axis=-1)
    return np.clip(2.0 * total, 0.0, 1.0)


def phase_sf(dphi, gamma2, n):
    """Two-sided tail of the sample phase: P(|arg C - arg rho| >= |dphi|) (dphi [rad] wrapped to [0, pi])."""
    dphi, gamma2, n = np.broadcast_arrays(*(np.asarray(a, float) for a in (dphi, gamma2, n)))
    t = np.abs((dphi + np.pi) % (2.0 * np.pi) - np.pi)
    kappa = (gamma2 / (2.0 * (1.0 - gamma2)))[..., None] * (2.0 * _gamma_nodes(n))
    return np.sum(_Q_WEIGHTS * _rice_phase_sf(t[..., None], kappa), axis=-1)


def normal_score(lower, upper):
    """Signed normal score of one-sided tail probabilities: Phi^-1(lower) if the lower tail is the smaller one,
    else Phi^-1(1 - upper); |z| > z_crit  <=>  the smaller tail < ALPHA / (2 n), as for a Gaussian z."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    return np.where(lower < upper, norm.ppf(np.maximum(lower, 1e-300)), norm.isf(np.maximum(upper, 1e-300)))


def coh2_z(g, gamma2, n):
    """Normal score [-] of an observed sample coherence ``g`` under (gamma2, n) (exact law, :func:`coh2_tails`)."""
    return normal_score(*coh2_tails(g, gamma2, n))


def phase_z(dphi, gamma2, n):
    """Signed normal score [-] of a phase deviation ``dphi`` [rad] (wrapped): sign(dphi) z with
    P(|error| >= |dphi|) = 2 Phi(-z) under (gamma2, n) (:func:`phase_sf`)."""
    wrapped = (np.asarray(dphi, float) + np.pi) % (2.0 * np.pi) - np.pi
    return np.sign(wrapped) * norm.isf(np.maximum(phase_sf(dphi, gamma2, n), 1e-300) / 2.0)


def cospectrum_tails(x, c, n):
    """(P(X <= x), P(X >= x)) of the sample co-coherence X = Re sum conj(u_i) w_i / n of n independent circular
    Gaussian pairs with unit variances and real coherency c (|c| < 1).

    X = (a G1 - b G2) / n, G1, G2 ~ Gamma(n, 1), a = (1 + c) / 2, b = (1 - c) / 2 (variance-gamma, exponential tails):
    a regularised incomplete gamma function given G2, integrated over G2 with Gauss-Hermite nodes."""
    x, c, n = np.broadcast_arrays(*(np.asarray(v, float) for v in (x, c, n)))
    a, b = (1.0 + c) / 2.0, (1.0 - c) / 2.0
    nn = n[..., None]
    arg = np.maximum((nn * x[..., None] + b[..., None] * _gamma_nodes(n)) / np.maximum(a, 1e-300)[..., None], 0.0)
    lower = np.sum(_Q_WEIGHTS * gammainc(nn, arg), axis=-1)
    upper = np.sum(_Q_WEIGHTS * gammaincc(nn, arg), axis=-1)
    return np.clip(lower, 0.0, 1.0), np.clip(upper, 0.0, 1.0)


def cospectrum_z(x, c, n):
    """Normal score [-] of an observed sample co-coherence ``x`` under (c, n) (exact law, :func:`cospectrum_tails`)."""
    return normal_score(*cospectrum_tails(x, c, n))
