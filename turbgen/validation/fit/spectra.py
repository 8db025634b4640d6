"""Welch estimates of F_uu, F_vv, F_ww and the u-w co-spectrum of fit data, in log-spaced bands, with their variances.

The validator's Welch setup (``estimators.WelchSetup``: Hann window, half-overlapping segments, segment mean removed;
default segment length ``default_nperseg``) on every column, skipping a column's segments that hold a missing value
(NaN). Bins 1 .. n/2 - 1 are averaged into BANDS_PER_DECADE bands per decade (each lowest bin on its own).

Variances (the fit's weights): a band of n bins of one point's Welch average over K segments has the variance S^2 times
sum_d (n - |d|) (r_d + 2 q o_d) / (n^2 K), r_d and o_d the correlations of white noise's Hann bins d apart in one and in
half-overlapping segments (``WelchSetup.bin_rho2``), q = (K - 1) / K: ``var_factor``. The joint covariance of the four
point-averaged spectra (``covariance``) scales with it (``BandSpectra.covariance``); neighbouring bands covary through
neighbouring Hann bins (``BandSpectra.full_covariance``)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from turbgen import fft
from turbgen.errors import ParameterError
from turbgen.validation.estimators import MIN_NPERSEG, WelchSetup, default_nperseg, segment_starts
from turbgen.validation.fit.covariance import joined
from turbgen.validation.fit.data import FitData

BANDS_PER_DECADE = 8
MIN_SEGMENTS = 4  # fewer complete segments per column than this: refused (no spectrum worth fitting)
SPECTRA = ("uu", "vv", "ww", "uw")


@dataclass(frozen=True, eq=False)
class BandSpectra:
    """Band-averaged one-sided Welch estimates [m^2 s^-2 Hz^-1] of fit data.

    ``var_factor``: the variance of one point's auto-spectrum estimate is factor S^2, that of its co-spectrum
    factor (S_uu S_ww + C^2) / 2. ``band_corr``: from the correlation of Hann bins up to 3 apart (neighbouring
    single-bin bands at low frequencies correlate by 4/9)."""

    setup: WelchSetup  # segment length and dt [s]
    nt: int  # record length [samples]
    bands: tuple  # bin indices of every band
    f_hz: np.ndarray  # (nbands,) band centre (mean bin frequency) [Hz]
    values: dict  # spectrum ("uu", "vv", "ww", "uw") -> (nbands,) estimate (the co-spectrum Re S_uw for "uw")
    var_factor: dict  # spectrum -> (nbands,) the band gain over K_eff
    segments: dict  # component -> complete segments used per column (summed over columns)
    band_corr: np.ndarray  # (nbands, nbands) correlation of the band averages

    def band_mean(self, binned: np.ndarray) -> np.ndarray:
        """(nbins,) values averaged over each band."""
        return np.array([binned[b].mean() for b in self.bands])

    def co_coherence(self, X: np.ndarray, ok: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(nbands,) co-coherence sum Re conj(X_a) X_b / sqrt(sum |X_a|^2 sum |X_b|^2) of the column pairs (a, b) of
        the DFTs ``X`` (``segment_dfts``, ``ok`` its complete segments), pooled over the pairs, segments and bins."""
        both = (ok[:, a] & ok[:, b])[:, None, :]
        c, aa, bb = (self.band_mean((v * both).sum(axis=(0, 2))) for v in (
            np.real(np.conj(X[:, :, a]) * X[:, :, b]), np.abs(X[:, :, a]) ** 2, np.abs(X[:, :, b]) ** 2))
        return c / np.sqrt(aa * bb)

    def covariance(self, used: tuple, expected: dict, isserlis: np.ndarray) -> np.ndarray:
        """(nbands, k, k) covariance of the band estimates of the k spectra ``used``: the normalised point-averaged
        Isserlis terms ``isserlis`` (``covariance.isserlis``) times sqrt(S_i S_j S_k S_l) of the ``expected`` auto
        spectra and the Welch factors of the two estimates."""
        auto = {c: expected[c + c] for c in "uvw" if c + c in expected}
        scale = np.stack([np.sqrt(auto[s[0]] * auto[s[1]] * self.var_factor[s]) for s in used], axis=1)  # (nb, k)
        return isserlis * scale[:, :, None] * scale[:, None, :]

    def full_covariance(self, used: tuple, expected: dict, isserlis: np.ndarray) -> np.ndarray:
        """(nbands k, nbands k) covariance of all band estimates (band-major: index band * k + spectrum): the
        per-band blocks (``covariance``) joined by ``band_corr`` (``turbgen.validation.fit.covariance.joined``)."""
        return joined(self.covariance(used, expected, isserlis), self.band_corr)


def band_bins(nperseg: int) -> tuple:
    """Bins 1 .. nperseg/2 - 1 grouped BANDS_PER_DECADE per decade (log-spaced edges; each band >= 1 bin)."""
    last = nperseg // 2 - 1
    edges = np.unique(np.round(np.geomspace(1, last + 1, int(BANDS_PER_DECADE * math.log10(last + 1)) + 2)))
    edges = edges.astype(int)
    return tuple(np.arange(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a)


def segment_dfts(x: np.ndarray, setup: WelchSetup) -> tuple[np.ndarray, np.ndarray]:
    """(K, nf, P) windowed, mean-removed DFTs of the segments of every column, (K, P) bool: segment complete."""
    xt = np.ascontiguousarray(x.T)  # (P, nt): each segment's samples contiguous for the FFT
    segs = np.stack([xt[:, s : s + setup.nperseg] for s in segment_starts(x.shape[0], setup)])  # (K, P, n)
    ok = np.all(np.isfinite(segs), axis=2)
    segs = np.where(ok[..., None], segs, 0.0)
    segs -= segs.mean(axis=2, keepdims=True)
    segs *= setup.window
    return fft.oneshot().rfft(segs, axis=2).transpose(0, 2, 1), ok


def estimate_bands(data: FitData, nperseg: int | None = None) -> BandSpectra:
    """BandSpectra: band-averaged Welch spectra of ``data`` and their variance factors (module docstring); ``nperseg``
    [samples] defaults to ``default_nperseg(nt)`` (about 15 half-overlapping segments). ParameterError for a record
    shorter than 4 MIN_NPERSEG, ``nperseg`` outside [MIN_NPERSEG, nt / 4], or a component with fewer than
    MIN_SEGMENTS complete segments per column (gaps)."""
    nt = data.nt
    if nt < 4 * MIN_NPERSEG:
        raise ParameterError(f"{data.source}: {nt} samples are too short a record to fit (needs >= {4 * MIN_NPERSEG}: "
                             f"4 Welch segments of {MIN_NPERSEG} for the lowest band)")
    n = nperseg or default_nperseg(nt)
    if not MIN_NPERSEG <= n <= nt // 4:
        raise ParameterError(f"nperseg = {n} is outside [{MIN_NPERSEG}, nt/4 = {nt // 4}] for a record of {nt} "
                             "samples")
    setup = WelchSetup(n, data.dt_s)
    bands, gram, over = band_bins(n), _band_gram(setup, 0), _band_gram(setup, setup.hop)
    values, factor, segs, dft = {}, {}, {}, {}
    for c, x in data.series.items():
        X, ok = segment_dfts(x, setup)
        k = ok.sum(axis=0)
        if k.min() < MIN_SEGMENTS:
            raise ParameterError(f"{data.source}: {c} has {int(k.min())} complete Welch segments of {n} samples in a "
                                 f"column (gaps or a short record); at least {MIN_SEGMENTS} are needed")
        dft[c], segs[c] = (X, ok), int(k.sum())
        psd = (np.abs(X) ** 2 * ok[:, None, :]).sum(axis=(0, 2)) * setup.scale / k.sum()
        values[c + c] = np.array([psd[b].mean() for b in bands])
        factor[c + c] = np.diag(gram + 2 * (1 - x.shape[1] / k.sum()) * over) * x.shape[1] / k.sum()
    if data.uw_columns:
        (xu, oku), (xw, okw) = dft["u"], dft["w"]
        iu, iw = (np.array(v) for v in zip(*data.uw_columns))
        both = oku[:, iu] & okw[:, iw]
        co = np.real(np.conj(xu[:, :, iu]) * xw[:, :, iw] * both[:, None, :]).sum(axis=(0, 2))
        co = co * setup.scale / max(both.sum(), 1)
        values["uw"] = np.array([co[b].mean() for b in bands])
        factor["uw"] = np.sqrt(factor["uu"] * factor["ww"])
    f, gram = setup.freqs, gram + 2 * (1 - 1 / len(segment_starts(nt, setup))) * over  # a whole column's (bands' corr.)
    return BandSpectra(setup, nt, bands, np.array([f[b].mean() for b in bands]), values, factor, segs,
                       gram / np.sqrt(np.outer(np.diag(gram), np.diag(gram))))


@lru_cache(maxsize=8)
def _band_gram(setup: WelchSetup, shift: int) -> np.ndarray:
    """(nbands, nbands) covariance of the band means of unit-variance bins correlated r_d = ``setup.bin_rho2(d, shift)``
    at d < 4 bins apart (read-only: cached)."""
    bands, r = band_bins(setup.nperseg), np.array([setup.bin_rho2(d, shift) for d in range(4)])
    nbins = bands[-1][-1] + 1
    lag = np.abs(np.arange(nbins)[:, None] - np.arange(nbins)[None, :])
    rb = np.where(lag < r.size, r[np.minimum(lag, r.size - 1)], 0.0)
    m = np.array([np.isin(np.arange(nbins), b) / b.size for b in bands])  # band means
    gram = m @ rb @ m.T
    gram.flags.writeable = False
    return gram
