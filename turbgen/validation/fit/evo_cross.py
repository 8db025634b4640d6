"""The covariance of the co-coherence estimates along x with the one-point band estimates of the same data.

Both are quadratic forms in the same Gaussian DFTs, so they covary: a realisation whose coherent large eddies carry
more energy raises the low-band spectra (L-hat up) and the co-coherence (gamma-hat up, as the coherence fixes about
L^2 / gamma). With X_i^a the DFT of component i at point a in one bin and segment, the co-coherence of the pair
(x_i, x_j) at the P points p is to first order rho + sum_p Z_p / (P S_u), Z_p = Re X_u^a conj X_u^c - rho (|X_u^a|^2
+ |X_u^c|^2) / 2, a = (x_i, p), c = (x_j, p); a spectrum s = (k, l) is the mean of Re X_k^b conj X_l^b over its
points b; and Cov(Re X_i^a conj X_j^c, Re X_k^b conj X_l^d) = Re(S_il^ad S_kj^bc + S_ik^ab S_lj^dc) / 2 (Isserlis
1918). With the model's coherencies at each band's centre (``model.BandModel.coherency``, the decay between planes at
gamma included; Guo et al. 2023, Eq. 13) this gives their correlation per band (the Welch factors cancel); bands are
joined by ``band_corr`` as the fit's own covariances are, and scaled by both estimates' standard deviations."""

from __future__ import annotations

import numpy as np

from turbgen.validation.fit.covariance import INDEX


def _cov4(g: np.ndarray, index: np.ndarray, ij: tuple, ac: tuple, kl: tuple, bd: tuple) -> np.ndarray:
    """(nbands,) Cov(Re X_i^a conj X_j^c, Re X_k^b conj X_l^d) / sqrt(S_i S_j S_k S_l), averaged over the points
    a, c (paired) and b, d (paired) (module docstring); ``g`` (nbands, 3, 3, D) coherencies at ``index``."""
    (i, j), (a, c), (k, l), (b, d) = ij, ac, kl, bd

    def at(p, q, u, v):  # (nb, len u, len v) coherency of component p at u with q at v
        return g[:, p, q][:, index[np.ix_(u, v)]]

    t = at(i, l, a, d) * at(k, j, b, c).swapaxes(1, 2) + at(i, k, a, b) * at(l, j, d, c).swapaxes(1, 2)
    return 0.5 * t.real.mean(axis=(1, 2))


def coherence_spectra_corr(g: np.ndarray, index: np.ndarray, pair_sites: list, sets: dict, used: tuple
                           ) -> np.ndarray:
    """(nbands, npairs, k) correlation of each pair's co-coherence estimate with each spectrum's (module docstring);
    ``pair_sites``: per pair of x values the (P,) site indices at x_i and at x_j of its points; ``sets``: spectrum ->
    site indices of its points (``covariance.point_sets``); ``index``: pair index into the separations of ``g``."""
    uu = (0, 0)
    out = np.empty((g.shape[0], len(pair_sites), len(used)))
    for m, (a, c) in enumerate(pair_sites):
        rho = g[:, 0, 0][:, index[a, c]].real.mean(axis=1)
        def z_with(kl, bd):  # noqa: E306 - Cov(Z, Re X_k^b conj X_l^d), the Z of this pair
            return _cov4(g, index, uu, (a, c), kl, bd) - rho / 2 * (
                _cov4(g, index, uu, (a, a), kl, bd) + _cov4(g, index, uu, (c, c), kl, bd))
        var_z = z_with(uu, (a, c)) - rho / 2 * (z_with(uu, (a, a)) + z_with(uu, (c, c)))
        for n, s in enumerate(used):
            kl, pts = (INDEX[s[0]], INDEX[s[1]]), (sets[s], sets[s])
            out[:, m, n] = z_with(kl, pts) / np.sqrt(var_z * _cov4(g, index, kl, pts, kl, pts))
    return out


def cross_covariance(corr: np.ndarray, band_corr: np.ndarray, sd_r: np.ndarray, sd_f: np.ndarray) -> np.ndarray:
    """(nbands npairs, nbands k) covariance, both band-major, of the co-coherences (sd ``sd_r`` (npairs, nbands))
    with the spectra (sd ``sd_f`` (k, nbands)) from their per-band correlation ``corr`` (nbands, npairs, k): band b
    with band c correlates by band_corr[b, c] times the mean of the two bands' correlations."""
    nb, npair, k = corr.shape
    c = band_corr[:, None, :, None] * 0.5 * (corr[:, :, None, :] + corr.transpose(1, 0, 2)[None])
    return (c * sd_r.T[:, :, None, None] * sd_f.T[None, None, :, :]).reshape(nb * npair, nb * k)
