"""Welch estimates of F_uu, F_vv, F_ww and the u-w co-spectrum of fit data, in log-spaced bands, with their variances.

The validator's Welch setup (``estimators.WelchSetup``: Hann window, half-overlapping segments, segment mean removed;
default segment length ``default_nperseg``) is applied to every column; a segment holding a missing value (NaN) of a
column is skipped for that column (Welch over the gaps). Bins are averaged into bands BANDS_PER_DECADE per decade
(each lowest bin on its own), bins 1 .. n/2 - 1.

Variances (the fit's weights): for a Gaussian process the periodograms of points a, b covary as |S_ab|^2 (Isserlis
1918), so the average over P points of one bin has the one-point variance S^2 / K_eff (Welch 1967; K_eff from the
segment overlap, ``WelchSetup.effective_segments``) times rho_bar = sum_ab coh2_ab / P^2, estimated from the data
for every band (``_rho_bar``: from products of non-overlapping segments, free of the bias of coherence estimates);
a band of n bins has the variance of one bin times
(n + 2 sum_d (n - d) r_d) / n^2, with r_d the correlation of Hann bins d apart (``WelchSetup.bin_rho2``). The
expected spectrum S itself comes from the model (``MannFit`` re-weights with the fitted model), so the weights do not
follow the noise of the estimates. The co-spectrum Re S_uw has the one-point variance (S_uu S_ww + Re S_uw^2) / (2
K_eff) (Bendat & Piersol 2010, Sect. 9.1) times the geometric mean of the u and w rho_bar; the estimates of one
band covary (Isserlis 1918: Cov(P_uu, P_ww) = C^2, Cov(P_uu, C) = S_uu C at one point, C the co-spectrum; v is
uncorrelated with u and w at one point, F_12 = F_23 = 0), scaled in the same way: ``BandSpectra.covariance``; and
neighbouring bands covary through the correlation of neighbouring Hann bins: ``BandSpectra.full_covariance``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from turbgen import fft
from turbgen.errors import ParameterError
from turbgen.validation.estimators import MIN_NPERSEG, WelchSetup, default_nperseg, segment_starts
from turbgen.validation.fit.data import FitData

BANDS_PER_DECADE = 8
MIN_SEGMENTS = 4  # fewer complete segments per column than this: refused (no spectrum worth fitting)
SPECTRA = ("uu", "vv", "ww", "uw")


@dataclass(frozen=True, eq=False)
class BandSpectra:
    """Band-averaged one-sided Welch estimates [m^2 s^-2 Hz^-1] of fit data.

    Attributes
    ----------
    setup : WelchSetup
        Segment length and dt [s].
    nt : int
        Record length [samples].
    bands : tuple of numpy.ndarray
        Bin indices of every band.
    f_hz : numpy.ndarray
        (nbands,) band centre (mean bin frequency) [Hz].
    values : dict
        Spectrum ("uu", "vv", "ww", "uw") -> (nbands,) estimate (the co-spectrum Re S_uw for "uw").
    var_factor : dict
        Spectrum -> (nbands,) the one-point variance factor times rho_bar and the band gain: the variance of an
        auto-spectrum estimate is factor S^2, that of the co-spectrum factor (S_uu S_ww + C^2) / 2.
    segments : dict
        Component -> complete segments used per column (summed over columns).
    band_corr : numpy.ndarray
        (nbands, nbands) correlation of the band averages from the correlation of Hann bins up to 3 apart
        (neighbouring single-bin bands at low frequencies correlate by 4/9).
    """

    setup: WelchSetup
    nt: int
    bands: tuple
    f_hz: np.ndarray
    values: dict
    var_factor: dict
    segments: dict
    band_corr: np.ndarray

    def band_mean(self, binned: np.ndarray) -> np.ndarray:
        """(nbins,) values averaged over each band."""
        return np.array([binned[b].mean() for b in self.bands])

    def covariance(self, used: tuple, expected: dict) -> np.ndarray:
        """(nbands, k, k) covariance of the band estimates of the k spectra ``used`` given the expected band spectra
        ``expected`` (module docstring)."""
        f = self.var_factor
        e = expected
        c2 = e["uw"] ** 2 if "uw" in e else 0.0
        var = {s: f[s] * e[s] ** 2 for s in ("uu", "vv", "ww") if s in used}
        if "uw" in used:
            var["uw"] = f["uw"] * (e["uu"] * e["ww"] + c2) / 2.0
        # one point: Cov(P_uu, P_ww) = C^2, Cov(P_uu, Re C_uw) = S_uu C, Cov(P_ww, Re C_uw) = S_ww C (Isserlis 1918);
        # the point average scales each by the geometric mean of the two estimates' factors
        cross = {("uu", "ww"): c2, ("uu", "uw"): e["uu"] * e.get("uw", 0.0), ("ww", "uw"): e["ww"] * e.get("uw", 0.0)}
        cov = np.zeros((self.f_hz.size, len(used), len(used)))
        for i, s in enumerate(used):
            cov[:, i, i] = var[s]
            for j, t in enumerate(used):
                if (s, t) in cross and t in used:
                    cov[:, i, j] = cov[:, j, i] = np.sqrt(f[s] * f[t]) * cross[(s, t)]
        return cov

    def full_covariance(self, used: tuple, expected: dict) -> np.ndarray:
        """(nbands k, nbands k) covariance of all band estimates (band-major: index band * k + spectrum): the
        per-band covariances (``covariance``) joined across bands by ``band_corr``, each cross-band pair of spectra
        with the mean of the two bands' correlations of that pair."""
        cov = self.covariance(used, expected)
        sd = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))  # (nb, k)
        corr = cov / (sd[:, :, None] * sd[:, None, :])
        nb, k = sd.shape
        pair = 0.5 * (corr[:, None] + corr[None, :])  # (nb, nb, k, k)
        full = self.band_corr[:, :, None, None] * pair * sd[:, None, :, None] * sd[None, :, None, :]
        return full.transpose(0, 2, 1, 3).reshape(nb * k, nb * k)


def band_bins(nperseg: int) -> tuple:
    """Bins 1 .. nperseg/2 - 1 grouped BANDS_PER_DECADE per decade (log-spaced edges; each band >= 1 bin)."""
    last = nperseg // 2 - 1
    edges = np.unique(np.round(np.geomspace(1, last + 1, int(BANDS_PER_DECADE * math.log10(last + 1)) + 2)))
    edges = edges.astype(int)
    return tuple(np.arange(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a)


def _segment_dfts(x: np.ndarray, setup: WelchSetup) -> tuple[np.ndarray, np.ndarray]:
    """(K, nf, P) windowed, mean-removed DFTs of the segments of every column, (K, P) bool: segment complete."""
    xt = np.ascontiguousarray(x.T)  # (P, nt): each segment's samples contiguous for the FFT
    segs = np.stack([xt[:, s : s + setup.nperseg] for s in segment_starts(x.shape[0], setup)])  # (K, P, n)
    ok = np.all(np.isfinite(segs), axis=2)
    segs = np.where(ok[..., None], segs, 0.0)
    segs -= segs.mean(axis=2, keepdims=True)
    segs *= setup.window
    return fft.oneshot().rfft(segs, axis=2).transpose(0, 2, 1), ok


def _rho_bar(X: np.ndarray, bands: tuple) -> np.ndarray:
    """(nbands,) rho_bar = sum_ab coh2_ab / P^2 of the P columns of X (K, nf, P) per band (module docstring).

    With G_ss' = sum_a conj(X_sa) X_s'a (segments s, s'), E|G_ss'|^2 = sum_ab |S_ab|^2 and E[G_ss G_s's'] = (sum_a
    S_aa)^2 for independent segments (Isserlis 1918), so the ratio of their means over the segment pairs at least two
    hops apart (no overlap) estimates rho_bar without the 1/K bias of a coherence estimate.
    """
    g = np.einsum("kfa,lfa->fkl", np.conj(X), X)  # (nf, K, K)
    k = g.shape[1]
    far = np.abs(np.arange(k)[:, None] - np.arange(k)[None, :]) >= 2
    diag = np.real(np.einsum("fkk->fk", g))
    num = (np.abs(g) ** 2)[:, far].sum(axis=1)
    den = (diag[:, :, None] * diag[:, None, :])[:, far].sum(axis=1)
    return np.array([np.clip(num[b].sum() / den[b].sum(), 1.0 / X.shape[2], 1.0) for b in bands])


def estimate_bands(data: FitData, nperseg: int | None = None) -> BandSpectra:
    """Band-averaged Welch spectra of ``data`` and their variance factors (module docstring).

    Parameters
    ----------
    data : FitData
        The fluctuation series.
    nperseg : int, optional
        Welch segment length [samples]; default ``default_nperseg(nt)`` (about 15 half-overlapping segments).

    Returns
    -------
    BandSpectra

    Raises
    ------
    ParameterError
        If the record is too short for a segment of ``MIN_NPERSEG`` samples, ``nperseg`` is outside [MIN_NPERSEG,
        nt / 4], or a component has fewer than MIN_SEGMENTS complete segments per column (gaps).
    """
    nt = data.nt
    if nt < 4 * MIN_NPERSEG:
        raise ParameterError(f"{data.source}: {nt} samples are too short a record to fit (needs >= {4 * MIN_NPERSEG}: "
                             f"4 Welch segments of {MIN_NPERSEG} for the lowest band)")
    n = nperseg or default_nperseg(nt)
    if not MIN_NPERSEG <= n <= nt // 4:
        raise ParameterError(f"nperseg = {n} is outside [{MIN_NPERSEG}, nt/4 = {nt // 4}] for a record of {nt} "
                             "samples")
    setup = WelchSetup(n, data.dt_s)
    bands = band_bins(n)
    gram = _band_gram(bands, np.array([setup.bin_rho2(d) for d in range(4)]))
    gain = np.diag(gram)
    values, factor, segs, dft = {}, {}, {}, {}
    for c, x in data.series.items():
        X, ok = _segment_dfts(x, setup)
        k = ok.sum(axis=0)
        if k.min() < MIN_SEGMENTS:
            raise ParameterError(f"{data.source}: {c} has {int(k.min())} complete Welch segments of {n} samples in a "
                                 f"column (gaps or a short record); at least {MIN_SEGMENTS} are needed")
        dft[c], segs[c] = (X, ok), int(k.sum())
        psd = (np.abs(X) ** 2 * ok[:, None, :]).sum(axis=(0, 2)) * setup.scale / k.sum()
        values[c + c] = np.array([psd[b].mean() for b in bands])
        k_eff = setup.effective_segments(int(k.sum()), int(k.sum() - x.shape[1])) / x.shape[1]
        rho = _rho_bar(X, bands)
        factor[c + c] = rho * gain / k_eff
    if data.uw_columns:
        (xu, oku), (xw, okw) = dft["u"], dft["w"]
        iu, iw = (np.array(v) for v in zip(*data.uw_columns))
        both = oku[:, iu] & okw[:, iw]
        co = np.real(np.conj(xu[:, :, iu]) * xw[:, :, iw] * both[:, None, :]).sum(axis=(0, 2))
        co = co * setup.scale / max(both.sum(), 1)
        values["uw"] = np.array([co[b].mean() for b in bands])
        factor["uw"] = np.sqrt(factor["uu"] * factor["ww"])
    f = setup.freqs
    return BandSpectra(setup, nt, bands, np.array([f[b].mean() for b in bands]), values, factor, segs,
                       gram / np.sqrt(np.outer(gain, gain)))


def _band_gram(bands: tuple, r: np.ndarray) -> np.ndarray:
    """(nbands, nbands) covariance of the band means of unit-variance bins correlated r_d at d bins apart (d < 4)."""
    nbins = bands[-1][-1] + 1
    lag = np.abs(np.arange(nbins)[:, None] - np.arange(nbins)[None, :])
    rb = np.where(lag < r.size, r[np.minimum(lag, r.size - 1)], 0.0)
    m = np.zeros((len(bands), nbins))
    for i, b in enumerate(bands):
        m[i, b] = 1.0 / b.size
    return m @ rb @ m.T
