"""The joint covariance of the band estimates of F_uu, F_vv, F_ww and Re F_uw, averaged over the points of fit data.

For Gaussian data the DFTs X_i^a (component i, point a) of one bin and segment have S_pq^ab = E X_p^a conj(X_q^b), and
Cov(Re X_i^a conj X_j^a, Re X_k^b conj X_l^b) = Re(S_il^ab S_kj^ba + S_ik^ab S_lj^ba) / 2 (Isserlis 1918; Bendat &
Piersol 2010, Sect. 9.1, for one point). Averaged over the points P_s of spectrum s = (i, j) and P_t of t = (k, l),
Cov(s, t) is the mean of that over a in P_s, b in P_t: with coherencies g_pq^ab = S_pq^ab / sqrt(S_pp S_qq) it is
``isserlis`` x sqrt(S_i S_j S_k S_l) x the Welch factor of the segments and band (``spectra``). The coherencies come
from the model (``model.BandModel.coherency``) at each band's centre, so the covariance is that of a model, positive
semi-definite by construction. Bands are joined by the correlation of Hann bins (``joined``): the Schur product of
that PD correlation with the Gram matrix of the per-band square roots, positive definite when every band's block is.
"""

from __future__ import annotations

import numpy as np

INDEX = {"u": 0, "v": 1, "w": 2}


def point_sets(data, used: tuple) -> dict:
    """Spectrum -> (P,) indices into ``data.sites_m`` of the points its estimate averages over."""
    out = {s: np.asarray(data.columns[s[0]]) for s in used if s != "uw"}
    if "uw" in used:
        out["uw"] = np.asarray(data.columns["u"])[[iu for iu, _ in data.uw_columns]]
    return out


def separations(sites_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distinct separations (D, 3) [m] of the ordered site pairs, (N, N) index of each pair's separation and
    (D,) index of each separation's negative (the pair reversed)."""
    d = np.round(sites_m[:, None, :] - sites_m[None, :, :], 6).reshape(-1, 3)
    seps, inverse = np.unique(d, axis=0, return_inverse=True)
    lookup = {tuple(v): k for k, v in enumerate(seps)}
    neg = np.array([lookup[tuple(-v + 0.0)] for v in seps])
    return seps, inverse.reshape(sites_m.shape[0], -1), neg


def isserlis(coh: np.ndarray, pair_index: np.ndarray, neg: np.ndarray, sets: dict, used: tuple) -> np.ndarray:
    """(nbands, k, k) normalised covariance of the point-averaged estimates of ``used`` (module docstring).

    Parameters
    ----------
    coh : numpy.ndarray
        (nbands, 3, 3, D) complex coherency g_pq at every distinct separation (``separations``).
    pair_index, neg : numpy.ndarray
        From ``separations``.
    sets : dict
        From ``point_sets``.
    used : tuple of str
        The spectra ("uu", "vv", "ww", "uw").
    """
    out = np.empty((coh.shape[0], len(used), len(used)))
    for a, s in enumerate(used):
        for b, t in enumerate(used[a:], start=a):
            (i, j), (k, l) = ((INDEX[c] for c in name) for name in (s, t))
            terms = coh[:, i, l] * coh[:, k, j][:, neg] + coh[:, i, k] * coh[:, l, j][:, neg]  # (nb, D)
            counts = np.bincount(pair_index[np.ix_(sets[s], sets[t])].ravel(), minlength=coh.shape[-1])
            out[:, a, b] = out[:, b, a] = 0.5 * (terms.real @ counts) / (sets[s].size * sets[t].size)
    return out


def joined(cov: np.ndarray, band_corr: np.ndarray) -> np.ndarray:
    """(nb k, nb k) covariance of all band estimates (band-major) from the per-band blocks ``cov`` (nb, k, k) and
    the (nb, nb) correlation of the bands: C[(b, s), (c, t)] = band_corr[b, c] (R_b R_c)[s, t], R_b the symmetric
    square root of block b (module docstring)."""
    lam, vec = np.linalg.eigh(cov)
    root = np.einsum("bij,bj,bkj->bik", vec, np.sqrt(np.clip(lam, 0.0, None)), vec)  # (nb, k, k)
    nb, k, _ = cov.shape
    gram = np.einsum("bsr,ctr->bsct", root, root)
    return (band_corr[:, None, :, None] * gram).reshape(nb * k, nb * k)
