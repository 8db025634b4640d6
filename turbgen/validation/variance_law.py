"""Law of the point-averaged variance estimate as a sum of independent gamma terms (its tails exact where it matters).

The estimate is s2 = (1/N) sum_p sum_{j >= 1} w_j |Z_jp|^2 over the N points (and planes) of the grid (w_j the pair
weight of line j, ``Theory.pair_weights``). The amplitudes of line j are circular Gaussian with covariance L_j C_j,
so line j contributes sum_k w_j L_j mu_jk E_jk with E_jk ~ Exp(1) independent and mu_jk the eigenvalues of C_j / N
(sum_k mu_jk = 1, sum_k mu_jk^2 = rho_bar(f_j)).

One moment-matched gamma law has far too light an upper tail when a few coherent modes dominate, so the top modes
of the lowest N_MODE_LINES lines enter exactly (shape-1 terms) and each line's other modes as one gamma term with
their exact mean and variance (per-line terms only above MAX_MODE_POINTS points). Tails by the Lugannani-Rice
saddlepoint formula (Lugannani & Rice 1980; Butler 2007, Eq. 1.11)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.stats import chi2, norm


N_MODE_LINES = 4  # lowest lines whose top modes enter exactly
N_MODES = 4  # top modes per such line
MAX_MODE_POINTS = 2048  # grids with more points get no modes (dense N x N coherency matrix: 67 MB at 2048)
SUBSPACE = 16  # block size of the subspace iteration of ``top_modes``
POWER_STEPS = 6  # its power steps
REST_FLOOR = 1e-9  # a line's remaining modes holding less than this fraction of its mean are dropped (rounding)


def top_modes(coherency: np.ndarray) -> np.ndarray:
    """The N_MODES largest eigenvalues of a Hermitian coherency matrix C (N, N) divided by N [-], followed by the exact
    ||C||_F^2 / N^2 (= rho_bar at the line).

    Subspace iteration from a fixed random block of SUBSPACE vectors (Halko, Martinsson & Tropp 2011, Alg. 4.4) and
    Rayleigh-Ritz: deterministic, O(N^2) per step; the error of the k-th value falls as
    (mu_{SUBSPACE+1} / mu_k)^(2 POWER_STEPS)."""
    n = coherency.shape[0]
    if n <= 2 * SUBSPACE:
        mu = np.linalg.eigvalsh(coherency)[::-1]
    else:
        q = np.random.default_rng(0).standard_normal((n, SUBSPACE)).astype(coherency.dtype)
        for _ in range(POWER_STEPS):  # Householder QR: a C of rank < SUBSPACE makes Cholesky QR's y^H y singular
            q = np.linalg.qr(coherency @ q)[0]
        mu = np.linalg.eigvalsh(np.conj(q.T) @ coherency @ q)[::-1]
    return np.append(np.clip(mu[:N_MODES] / n, 0.0, None), np.sum(np.abs(coherency) ** 2) / n**2)


def gamma_terms(line_means: np.ndarray, line_rho: np.ndarray, modes: np.ndarray | None = None):
    """Shapes alpha [-] and scales theta [m^2 s^-2] of the gamma terms of the variance estimate (module docstring):
    ``line_means`` (nl,) w_j L_j of lines j = 1 .. [m^2 s^-2], ``line_rho`` (nl,) rho_bar(f_j) [-], ``modes`` (J, K + 1)
    ``top_modes`` of lines 1 .. J [-] (the last column replaces ``line_rho`` there)."""
    m = np.asarray(line_means, float)
    rho = np.asarray(line_rho, float)
    modes = np.zeros((0, 2)) if modes is None or np.size(modes) == 0 else np.asarray(modes, float)[: m.size]
    top = np.zeros((m.size, modes.shape[1] - 1))
    top[: modes.shape[0]] = modes[:, :-1]
    rho = rho.copy()
    rho[: modes.shape[0]] = modes[:, -1]
    rest_mean = m * np.clip(1.0 - top.sum(axis=1), 0.0, None)
    rest_var = m**2 * np.clip(rho - np.sum(top**2, axis=1), 0.0, None)
    # a rest below REST_FLOOR of its line is the rounding residue of 1 - sum(mu) (a rank-1 line): its ratio
    # rest_var / rest_mean would be a term of shape ~1e-16 and arbitrary scale that caps the saddlepoint bracket
    keep = (rest_mean > REST_FLOOR * m) & (rest_var > 0)
    alpha = np.concatenate([np.ones(np.count_nonzero(top)), rest_mean[keep] ** 2 / rest_var[keep]])
    theta = np.concatenate([(m[:, None] * top)[top > 0], rest_var[keep] / rest_mean[keep]])
    return alpha, theta


def gamma_sum_tails(x: float, alpha: np.ndarray, theta: np.ndarray) -> tuple[float, float]:
    """(P(S <= x), P(S >= x)) of S = sum_i Gamma(alpha_i, theta_i), independent (saddlepoint, Lugannani-Rice); ``x`` in
    the units of ``theta``; at the mean (0/0 in the formula) the moment-matched gamma law is used."""
    mean = float(np.sum(alpha * theta))
    var = float(np.sum(alpha * theta**2))
    if not x > 0:
        return 0.0, 1.0
    if abs(x - mean) < 1e-3 * np.sqrt(var):  # the saddlepoint formula is 0/0 at the mean: moment-matched gamma
        nu = 2.0 * mean**2 / var
        return float(chi2.cdf(nu * x / mean, nu)), float(chi2.sf(nu * x / mean, nu))

    def k1(t):
        return float(np.sum(alpha * theta / (1.0 - theta * t)))

    # the saddlepoint K'(t) = x: 0 < t < 1 / max theta above the mean; below, K'(t) < sum(alpha) / |t| for t < 0
    bracket = (0.0, (1.0 - 1e-15) / theta.max()) if x > mean else (-2.0 * alpha.sum() / x, 0.0)
    t = brentq(lambda s: k1(s) - x, *bracket, xtol=1e-300, rtol=1e-14, maxiter=500)
    k = -float(np.sum(alpha * np.log1p(-theta * t)))
    k2 = float(np.sum(alpha * (theta / (1.0 - theta * t)) ** 2))
    w = np.sign(t) * np.sqrt(max(2.0 * (t * x - k), 0.0))
    u = t * np.sqrt(k2)
    upper = float(norm.sf(w) + norm.pdf(w) * (1.0 / u - 1.0 / w))
    lower = float(norm.cdf(w) - norm.pdf(w) * (1.0 / u - 1.0 / w))
    return min(max(lower, 0.0), 1.0), min(max(upper, 0.0), 1.0)
