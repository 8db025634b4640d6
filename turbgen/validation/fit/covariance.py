"""The joint covariance of the band estimates of F_uu, F_vv, F_ww and Re F_uw, averaged over the points of fit data.

For Gaussian data the DFTs X_i^a (component i, point a) of one bin and segment have S_pq^ab = E X_p^a conj(X_q^b), and
Cov(Re X_i^a conj X_j^a, Re X_k^b conj X_l^b) = Re(S_il^ab S_kj^ba + S_ik^ab S_lj^ba) / 2 (Isserlis 1918; Bendat &
Piersol 2010, Sect. 9.1, for one point). Averaged over the points P_s of spectrum s = (i, j) and P_t of t = (k, l),
Cov(s, t) is the mean of that over a in P_s, b in P_t: with coherencies g_pq^ab = S_pq^ab / sqrt(S_pp S_qq) it is
``isserlis`` x sqrt(S_i S_j S_k S_l) x the Welch factor of the segments and band (``spectra``). The coherencies come
from the model (``model.BandModel.coherency``) at each band's centre, so the covariance is that of a model, positive
semi-definite by construction. Bands are joined by the correlation of Hann bins (``joined``): the Schur product of
that PD correlation with the Gram matrix of the per-band square roots, positive definite when every band's block is.

The lowest bins collect by leakage lines from ~0.3 to ~2 x their frequency, more coherent across points and segments
than the band centre says. On a periodic record (a store, or a sensor's record taken as periodic) a bin's Welch
estimate is a quadratic form in the DFT lines Y_q: ``line_covariance`` (Isserlis over the segment pairs) gives the
exact covariance of the bands within bins 1 .. EXACT_BINS, ``spliced`` in."""

from __future__ import annotations

import numpy as np

from turbgen.validation.estimators import segment_starts
from turbgen.validation.welch_kernel import segment_gain

INDEX = {"u": 0, "v": 1, "w": 2}
EXACT_BINS = 8  # Welch bins 1 .. EXACT_BINS: covariance from the record's lines (module docstring)
LINE_BAND = 8  # lines up to this many bins above EXACT_BINS enter (Hann leakage falls as bin^-6)


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


def exact_lines(nt: int, nperseg: int) -> int:
    """Number Q of the record's lines 1 .. Q that the estimates of bins 1 .. EXACT_BINS collect (``line_covariance``)."""
    return min((EXACT_BINS + LINE_BAND) * nt // nperseg, nt // 2 - 1)


def line_covariance(cross: np.ndarray, setup, nt: int, pair_index: np.ndarray, sets: dict, used: tuple
                    ) -> np.ndarray:
    """(EXACT_BINS, k, EXACT_BINS, k) covariance of the point-averaged Welch estimates of bins 1 .. EXACT_BINS of
    the spectra ``used`` on an nt-periodic record (module docstring).

    X^ia of bin m, segment start t, point a is sum_q Y_q^ia c_m(q) e^(i 2 pi q t / nt) (``segment_gain``), so with
    S_q(d) = E Y_q^a conj Y_q^b at d = r_a - r_b, A^ik = E X_m^ia conj X_n^kb = sum_q S_q^ik c_m(q) conj c_n(q)
    e^(i 2 pi q T / nt) and B^ik = E X_m^ia X_n^kb (c_n(-q) for conj c_n(q)) at start difference T, and
    Cov(Re X^i conj X^j, Re X^k conj X^l) = Re(A^ik conj A^jl + B^il conj B^jk + A^il conj A^jk + B^ik conj B^jl) / 2
    (Isserlis 1918), summed over the segment pairs and averaged over the point pairs of the two spectra.

    ``cross`` (Q, 3, 3, D) are S_q at the lines q = 1 .. Q and the separations of ``pair_index`` (``separations``);
    S_-q = conj S_q (a real record). The same sums, regrouped: A = u Re S + i v Im S over q > 0 (real arithmetic),
    bins m <= n (symmetric), T mod nt (the phase's period), the counts weighing a Gram of the S^ik per bin pair."""
    nq, (m, n) = cross.shape[0], np.triu_indices(EXACT_BINS)
    q = np.concatenate([np.arange(1, nq + 1), -np.arange(1, nq + 1)])  # the lines q, then -q
    c = segment_gain(np.arange(1, EXACT_BINS + 1)[:, None], q / (nt * setup.dt_s), setup)  # (M, 2Q)
    starts = np.asarray(segment_starts(nt, setup))
    lag, count = np.unique((starts[:, None] - starts[None, :]) % nt, return_counts=True)
    w = (np.stack([c[m] * np.conj(c[n]), c[m] * np.roll(c[n], nq, axis=1)])[:, :, None]
         * np.exp(2j * np.pi * np.outer(lag, q) / nt))  # (2, P, T, 2Q): the weights of A, B at q, -q
    u, v = w[..., :nq] + w[..., nq:], w[..., :nq] - w[..., nq:]  # the weights at q plus, minus those at -q
    left = np.stack([np.concatenate([u.real, -v.imag], -1), np.concatenate([u.imag, v.real], -1)], 3)
    flat = cross.reshape(nq, 9, -1)  # the 9 S^ik, each distinct one formed once (the model's S^ki = S^ik)
    keep, inv = np.unique([next(p for p in range(9) if p == r or np.array_equal(flat[:, p], flat[:, r]))
                           for r in range(9)], return_inverse=True)
    left, s_q = left.reshape(-1, 2 * nq), np.concatenate([flat[:, keep].real, flat[:, keep].imag])
    gram, tri = {}, np.empty((m.size, len(used), len(used)))
    for x, s in enumerate(used):
        for y, t in enumerate(used):
            (i, j), (k, l) = ((INDEX[ch] for ch in name) for name in (s, t))
            ik, jl, il, jk = inv[[3 * i + k, 3 * j + l, 3 * i + l, 3 * j + k]]
            counts = np.bincount(pair_index[np.ix_(sets[s], sets[t])].ravel(), minlength=cross.shape[-1])
            if (key := counts.tobytes()) not in gram:  # sum_T,d count_T counts_d X_p X_r, X = Re, Im of A, B
                ab = left @ (s_q * np.sqrt(counts)).reshape(2 * nq, -1)  # Re, Im of A, B times sqrt(counts_d)
                ab = ab.reshape(2, m.size, 2 * lag.size, keep.size, -1)
                gram[key] = np.einsum("zptkl,t->zpkl", ab @ ab.swapaxes(-1, -2), np.repeat(count, 2))
            g = gram[key]
            tri[:, x, y] = (g[0, :, ik, jl] + g[1, :, il, jk] + g[0, :, il, jk] + g[1, :, ik, jl]) / (
                2 * sets[s].size * sets[t].size)
    out = np.empty((EXACT_BINS, len(used), EXACT_BINS, len(used)))
    out[m, :, n, :], out[n, :, m, :] = tri, tri.swapaxes(1, 2)
    scale = setup.scale[1 : EXACT_BINS + 1] / starts.size
    return out * scale[:, None, None, None] * scale[None, None, :, None]


def spliced(full: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """``full`` (band-major covariance) with its leading block replaced by ``exact``: C -> T C T^T, T = diag(L_x
    L_0^-1, 1) with L_x, L_0 the Cholesky factors of ``exact`` and of the block it replaces (the cross terms to the
    other bands transformed alike), positive definite when both are."""
    n = exact.shape[0]
    t = np.linalg.cholesky(exact) @ np.linalg.inv(np.linalg.cholesky(full[:n, :n]))
    out = full.copy()
    out[:n] = t @ out[:n]
    out[:, :n] = out[:, :n] @ t.T
    return out
