"""The (k2, k3) quadrature behind the Mann spectra (Guo et al. 2023, Eq. 8, 16 and 24).

F_ij(k1, dy, dz) = ∫ Phi_ij(k) exp(i(k2 dy + k3 dz)) dk2 dk3 (Eq. 8) in polar coordinates
k2 = kappa cos(theta), k3 = kappa sin(theta), on which beta(|k|) is constant:

* Radial: Gauss-Legendre panels (N_GAUSS nodes, PANEL_LN wide in ln kappa) over kappa = s [X_LO, X_HI],
  s = sqrt(k1^2 + L^-2) the integrand's scale, plus the kappa^(-8/3) inertial tail in closed form. At
  k1 L << 1 the distortion puts a finite part of F_ij at kappa ~ |k1|, so the lower end moves to
  1e-3 |k1|, and k1 = 0 is evaluated as the limit k1 -> 0 (at k1 L = K1_ZERO): the tensor's own k1 = 0
  plane lacks that energy.
* Angle: trapezoid rule (spectral for the periodic integrand), N_THETA nodes, more at small k1 L where
  the integrand has angular features of width ~k1/kappa around k2 = 0.
* With a separation d = sqrt(dy^2 + dz^2) > 0: Jacobi-Anger on the angular Fourier coefficients c_n,
  ∫ Phi e^{i kappa d cos(theta - theta_d)} dtheta = 2 pi sum_n c_n i^n J_n(kappa d) e^{i n theta_d},
  exact in angle; radial sub-panels no wider than pi/d, the range cut where the dropped oscillating
  tail is below SEP_TAIL of F_ii."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache

import numpy as np

from turbgen import fft
from turbgen.errors import ParameterError, check_finite
from turbgen.theory.eddy_lifetime import shear_distortion_beta
from turbgen.theory.lattice import gauss_panel
from turbgen.theory.params import MannParams

N_GAUSS = 8  # Gauss-Legendre nodes per radial panel
N_THETA = 64  # trapezoid nodes in angle
PANEL_LN = 1.0  # radial panel width in ln(kappa)
X_LO, X_HI = 1e-6, 1e4  # radial range in units of s = sqrt(k1^2 + L^-2)
SEP_TAIL = 3e-5  # target size of the dropped radial tail with a separation (see _separated_cut)
K1_ZERO = 1e-8  # k1 L used for k1 = 0 (the limit; see perpendicular_quadrature)
_CHUNK_POINTS = 400_000  # tensor evaluations per batch (bounds memory)
_QUADRATURE_THREADS = min(os.cpu_count() or 1, 4)  # batches evaluated at once (memory: ~0.1 GB each)

@lru_cache(maxsize=8)
def gauss(n: int):
    """Gauss-Legendre nodes and weights on [0, 1]."""
    return gauss_panel(0.0, 1.0, n)


@lru_cache(maxsize=64)
def _radial_rule(x_lo: float, x_hi: float, panel_ln: float, n_gauss: int, max_width_over_s: float,
                 split_below: float = np.inf, tail: bool = False):
    """Nodes x and weights w with ∫ g(x) x dx ≈ sum w g(x) on [x_lo, x_hi] (x = kappa / s).

    Panels uniform in ln x (width <= panel_ln); those starting below ``split_below`` are split so that no
    sub-panel is wider than ``max_width_over_s``. With ``tail`` a last node at x_hi of weight (3/5) x_hi^2
    adds ∫_{x_hi}^inf g x dx of g ~ x^(-11/3)."""
    gx, gw = gauss(n_gauss)
    n_pan = int(np.ceil(np.log(x_hi / x_lo) / panel_ln))
    edges = np.log(x_lo) + np.arange(n_pan + 1) * (np.log(x_hi / x_lo) / n_pan)
    sub = []
    for a, b in zip(edges[:-1], edges[1:]):
        # m sub-panels uniform in ln x: the widest (last) one is e^b (1 - e^(-(b - a)/m)) wide
        m = 1
        if np.exp(a) < split_below and max_width_over_s < np.exp(b) - np.exp(a):
            m = int(np.ceil((b - a) / -np.log1p(-max_width_over_s / np.exp(b))))
        sub.append(np.linspace(a, b, m + 1))
    lo = np.concatenate([s[:-1] for s in sub])
    hi = np.concatenate([s[1:] for s in sub])
    t = lo[:, None] + (hi - lo)[:, None] * gx[None, :]
    x = np.exp(t).ravel()
    w = ((hi - lo)[:, None] * gw[None, :]).ravel() * x * x  # dx x = x^2 d(ln x)
    if tail:
        x, w = np.append(x, x_hi), np.append(w, 0.6 * x_hi * x_hi)
    return x, w


def _separated_cut(sd: float) -> float:
    """Radial cut x = kappa/s with a separation d (s d = ``sd``), between 4 and X_HI.

    The dropped tail is ~x^(-5/3) of F_ii, reduced by ~(x s d)^(-3/2) by its oscillation when x s d > 1;
    the cut keeps this estimate below SEP_TAIL."""
    sd = min(max(sd, 1e-300), 1e300)
    x = (SEP_TAIL * sd**1.5) ** (-6.0 / 19.0)
    if x * sd < 1.0:  # no cancellation to count on
        x = SEP_TAIL ** -0.6
    return float(np.clip(round(x, 1), 4.0, X_HI))


def check_k1(k1) -> np.ndarray:
    """``k1`` [rad/m] as a float array of at least one value; ParameterError for none, non-numbers or non-finite."""
    try:
        k1 = np.atleast_1d(np.asarray(k1, dtype=float))
    except (TypeError, ValueError):
        raise ParameterError(f"k1 (rad/m) = {k1!r:.60} must be finite numbers") from None
    if k1.size == 0:
        raise ParameterError("k1 (rad/m) is empty: give at least one wavenumber")
    if not np.all(np.isfinite(k1)):
        raise ParameterError("k1 (rad/m) must be finite numbers")
    return k1


def perpendicular_quadrature(
    k1, params: MannParams, pairs, dy_m: float = 0.0, dz_m: float = 0.0, resolve_m: float = 0.0,
    resolve_kappa_max: float = np.inf, _rule=None, weight=None
):
    """Angular integrals on the radial nodes of the (k2, k3) plane for every k1 [rad/m] and tensor pair (i, j):
    (kappa, weights, G), (len(k1), n_r) radial nodes [rad/m] and weights [rad^2/m^2] (∫ g kappa dkappa ≈ sum
    weights g; padding nodes weigh 0), G[(i, j)] = ∫_0^{2pi} Phi_ij exp(i kappa d cos(theta - theta_d)) dtheta
    [m^5 s^-2] at the separation (``dy_m``, ``dz_m``) [m]. Without one, the radial panels resolve exp(i kappa
    ``resolve_m``) below ``resolve_kappa_max`` [rad/m]; ``_rule``: internal overrides of the rule's constants;
    ``weight(pair, k1, kappa, cos theta, sin theta)`` multiplies Phi_ij in the angle integral (no separation)."""
    k1 = check_k1(k1)
    k1 = np.where(k1 == 0, K1_ZERO / params.length_scale_m, k1)
    dy = check_finite("dy (m)", dy_m)
    dz = check_finite("dz (m)", dz_m)
    d = float(np.hypot(dy, dz))
    resolve_m = check_finite("resolution length (m)", resolve_m)
    rule = _rule or {}
    s_all = np.sqrt(k1 * k1 + params.length_scale_m**-2)
    per_k1 = []
    x_hi = rule.get("x_hi", X_HI)
    panel_ln, n_gauss = rule.get("panel_ln", PANEL_LN), rule.get("n_gauss", N_GAUSS)
    kappa_res = np.broadcast_to(np.asarray(resolve_kappa_max, dtype=float), k1.shape)
    for s, k_res, k1_abs in zip(s_all, kappa_res, np.abs(k1)):
        # three decades below |k1|, rounded to a power of 10 so rules are reused
        x_lo = min(rule.get("x_lo", X_LO), 10.0 ** np.floor(np.log10(1e-3 * k1_abs / s)))
        if d > 0:  # oscillating integrand: resolve it up to a cut that bounds the dropped tail
            cut = rule.get("x_hi_sep", _separated_cut(s * d))
            per_k1.append(_radial_rule(x_lo, cut, panel_ln, n_gauss, float(np.pi / (d * s))))
        elif resolve_m > 0:  # smooth angular integrals, an oscillating radial weight below resolve_kappa_max
            per_k1.append(_radial_rule(x_lo, x_hi, panel_ln, n_gauss, float(np.pi / (resolve_m * s)),
                                       float(k_res / s), True))
        else:
            per_k1.append(_radial_rule(x_lo, x_hi, panel_ln, n_gauss, np.inf, np.inf, True))
    n_r = max(len(x) for x, _ in per_k1)
    kappa = np.empty((k1.size, n_r))
    weights = np.zeros((k1.size, n_r))
    for m, ((x, w), s) in enumerate(zip(per_k1, s_all)):
        kappa[m, : x.size] = x * s
        kappa[m, x.size :] = x[-1] * s  # padding nodes carry zero weight
        weights[m, : x.size] = w * s * s
    n_nodes = np.array([x.size for x, _ in per_k1])
    out = {p: np.zeros(kappa.shape, dtype=complex if d > 0 else float) for p in pairs}
    n_theta_all = _angle_count(np.abs(k1) * params.length_scale_m, rule)
    batches = []
    for n_theta in np.unique(n_theta_all):
        theta = 2.0 * np.pi * np.arange(n_theta) / n_theta
        cos_t, sin_t = np.cos(theta), np.sin(theta)
        idx = np.flatnonzero(n_theta_all == n_theta)
        idx = idx[np.argsort(n_nodes[idx], kind="stable")]  # similar node counts share a batch
        start = 0
        while start < idx.size:
            rows = max(1, _CHUNK_POINTS // (int(n_nodes[idx[start]]) * n_theta))
            batches.append((idx[start : start + rows], cos_t, sin_t))
            start += rows

    from turbgen.theory.sheared_tensor_samples import sheared_tensor_on_circles  # numba: imported when needed

    def batch(sl, cos_t, sin_t) -> None:
        nr = int(n_nodes[sl].max())  # only the padding beyond the longest row in the batch is skipped
        kk = kappa[sl, :nr]
        kk1 = k1[sl, None]
        beta = shear_distortion_beta(np.sqrt(kk1 * kk1 + kk * kk), params)
        phi = sheared_tensor_on_circles(k1[sl], kk, beta, cos_t, sin_t, pairs, params.ae, params.length_scale_m)
        for m, p in enumerate(pairs):
            if d == 0:
                v = phi[m] if weight is None else phi[m] * weight(p, k1[sl, None, None], kk[..., None], cos_t, sin_t)
                out[p][sl, :nr] = 2.0 * np.pi * v.mean(axis=-1)
            else:
                out[p][sl, :nr] = _jacobi_anger(phi[m], kk * d, float(np.arctan2(dz, dy)))

    # disjoint rows of ``out`` per batch: the threads (numpy leaves the GIL) change who computes which, not the numbers
    with ThreadPoolExecutor(min(len(batches), _QUADRATURE_THREADS)) as pool:
        list(pool.map(lambda b: batch(*b), batches))
    return kappa, weights, out


def _angle_count(k1L, rule):
    """Trapezoid nodes in angle per k1 L: more below k1 L = 0.3 and 0.01 (module docstring)."""
    if "n_theta" in rule:
        return np.full(k1L.shape, int(rule["n_theta"]))
    return np.where(k1L >= 0.3, N_THETA, np.where(k1L >= 0.01, 4 * N_THETA, 8 * N_THETA))


def _jacobi_anger(samples, z, theta_d: float):
    """2 pi sum_n c_n i^n J_n(z) e^{i n theta_d} from equispaced angular samples (last axis).

    c_n are the angular Fourier coefficients; orders with J_n(max z) < ~1e-17 are skipped."""
    n_theta = samples.shape[-1]
    c = fft.oneshot().fft(samples, axis=-1) / n_theta
    z_max = float(np.max(z))
    n_max = int(min(n_theta // 2 - 1, np.ceil(z_max + 12.0 * np.cbrt(z_max) + 25.0)))
    orders = np.arange(-n_max, n_max + 1)
    j_pos = _bessel_j(n_max, z)
    j_all = j_pos[..., np.abs(orders)] * np.where(orders < 0, (-1.0) ** np.abs(orders), 1.0)
    phase = (1j) ** (orders % 4) * np.exp(1j * orders * theta_d)
    return 2.0 * np.pi * (c[..., orders] * j_all * phase).sum(axis=-1)


def _bessel_j(n_max: int, z) -> np.ndarray:
    """J_0 .. J_n_max at z >= 0, (*z.shape, n_max + 1): Miller's backward recurrence J_(n-1) = (2n/z) J_n - J_(n+1)
    from an even order above n_max and z, normalised by J_0 + 2 sum J_2k = 1 (Abramowitz & Stegun 1964, Eq. 9.1.27
    and 9.1.46), to ~1e-14 absolute: all orders in one sweep, where scipy's jv evaluates each order apart."""
    z = np.maximum(np.asarray(z, dtype=float), 1e-100)  # 2n/z finite; J_n below z = 1e-100 is J_n(0) to 1e-100
    top = int(max(n_max, z.max()))
    top += 20 + int(np.sqrt(160.0 * top)) + top % 2
    out = np.empty((*z.shape, n_max + 1))
    upper, f, norm = np.zeros(z.shape), np.full(z.shape, 1e-250), np.zeros(z.shape)
    for n in range(top, 0, -1):
        if n <= n_max:
            out[..., n] = f
        if n % 2 == 0:
            norm += 2.0 * f
        f, upper = (2.0 * n / z) * f - upper, f
        big = np.abs(f) > 1e200  # rescaled before they overflow
        if big.any():
            f[big], upper[big], norm[big] = f[big] * 1e-200, upper[big] * 1e-200, norm[big] * 1e-200
            out[big, n:] *= 1e-200
    out[..., 0] = f
    return out / (norm + f)[..., None]
