"""Spectra of a sonic anemometer: each component averaged along its acoustic path of length p (0 < p << L).

Geometry: each component measured along a path parallel to it, u along x, v along y, w along z (the idealised
probe of Kaimal et al. 1968; tilted real paths: Horst 1973, van Dijk 2002). A line average along e multiplies a mode
by sinc(k.e p/2): F^p_ij(k1) = ∫∫ Phi_ij sinc(k.e_i p/2) sinc(k.e_j p/2) dk2 dk3, and T = F^p / F is that of the
isotropic inertial range, a function of a = k1 p: sinc^2(a/2) for u (exact for any tensor); for v (w alike) the
k3 integral of Phi_22 = C k^(-11/3) (1 - k2^2/k^2) is closed, leaving T(a) = ∫ g sinc^2(a q/2) dq / ∫ g dq with
q = k2/k1, g = A^(-4/3) - (8/11) q^2 A^(-7/3), A = 1 + q^2. The isotropic u-w co-spectrum is 0: its T is taken as
sqrt(T_uu T_ww), within 0.025 of the Mann (1994) tensor's at p/L = 0.005 up to k1 p = 3 (v, w: 1e-3; the tests)."""

from functools import lru_cache

import numpy as np
from scipy.integrate import quad

A_NODES = np.geomspace(1e-3, 1e4, 141)  # tabulated a = k1 p; below: 1 - T ~ a^(5/3), above: T ~ 1 / a


def _g(q):
    return (1 + q * q) ** (-4 / 3) - 8 / 11 * q * q * (1 + q * q) ** (-7 / 3)


@lru_cache(maxsize=1)
def _perpendicular_table() -> np.ndarray:
    """T of v, w at A_NODES: q > 0 split at 20 / a; beyond, sinc^2 = 2 (1 - cos a q) / (a q)^2, the cosine by QAWF."""
    out = []
    for a in A_NODES:
        x, h = 20.0 / a, lambda q, a=a: 2 * _g(q) / (a * q) ** 2
        near = quad(lambda q, a=a: _g(q) * np.sinc(a * q / (2 * np.pi)) ** 2, 0, x, limit=400)[0]
        out.append(near + quad(h, x, np.inf)[0] - quad(h, x, np.inf, weight="cos", wvar=a)[0])
    return np.array(out) / quad(_g, 0, np.inf)[0]


def path_transfer(k1_p) -> dict:
    """Name ("uu", "vv", "ww", "uw") -> T(k1 p) [-] of the path-averaged spectra (module docstring) at ``k1_p``."""
    a = np.abs(np.asarray(k1_p, dtype=float))
    t, lo, hi = _perpendicular_table(), A_NODES[0], A_NODES[-1]
    perp = np.exp(np.interp(np.log(np.clip(a, lo, hi)), np.log(A_NODES), np.log(t)))  # 7e-4 of T at most
    perp = np.where(a < lo, 1 - (1 - t[0]) * (a / lo) ** (5 / 3), perp)
    perp = np.where(a > hi, t[-1] * hi / np.maximum(a, hi), perp)
    uu = np.sinc(a / (2 * np.pi)) ** 2
    return {"uu": uu, "vv": perp, "ww": perp, "uw": np.sqrt(uu * perp)}
