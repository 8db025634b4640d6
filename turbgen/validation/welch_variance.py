"""Exact covariance of Welch estimates of an nt-periodic Gaussian line process (short records).

Theory side of the tolerances (independent of the generator): the model on the record is a
sum of lines q = 0 .. nt-1 (frequency q / (nt dt), q > nt/2 the negative frequencies) with
independent circular Gaussian amplitudes Y_q, E|Y_q|^2 = L_q and Y_{nt-q} = conj(Y_q) (real
field). A segment starting at sample t0 has the windowed, mean-removed DFT

    X_{t0, m} = sum_q Y_q c_m(q) exp(i 2 pi q t0 / nt),   c_m(q) = G_m(q / (nt dt))

(G_m of ``welch_kernel.WelchKernel``: Hann DTFT minus the segment-mean term), so by Isserlis

    Cov(|X_{s,m}|^2, |X_{s',m'}|^2) = |A|^2 + |B|^2,
    A = sum_q L_q c_m(q) conj(c_m'(q)) e^{i 2 pi q D / nt},   B = sum_q L_q c_m(q) c_m'(nt - q) e^{i 2 pi q D / nt},

D = t0_s - t0_s'. Summed over all segment pairs this is the exact variance of the Welch average of one
point, including everything the "K_eff = K / (1 + 2 rho_w ...)" rule of thumb leaves out: the actual
segment starts (segments lost at span edges), overlap for a coloured spectrum, correlation of
non-overlapping segments where the spectrum varies within a bin (low bins of short records), the
per-segment mean removal, and the correlation of neighbouring bins for a coloured spectrum.

Averages over N points/planes (``averaged``): point p, q have line cross-covariances L_q coh_pq(f_q), so
A and B of the pair carry coh_pq inside the line sum, and the covariance of the average is

    (1 / N^2) sum_pq (|A_pq|^2 + |B_pq|^2) = sum_ij a_i conj(a_j) R(nu_i, nu_j)   (same for B),

with coh_pq(f) interpolated (linear in log f) between frequency nodes nu_i, a_i the line sums of A with
line q weighted by the interpolation weight of node i, and R(nu_i, nu_j) = sum_pq coh_pq(nu_i)
conj(coh_pq(nu_j)) / N^2 the two-frequency correlation sum of the point set (``Theory.rho_*``). Taking
R(f_m, f_m) for every line instead (the one-node rule ``rho_bar(f_m) x one-point covariance``) misses
that the lowest Welch bins collect lines from ~0.3 f_m to ~2 f_m by leakage, and the coherence of
those lower lines is higher: measured over 400 correct Kaimal fields (nt 512, 12 x 12 x 2 planes) the
spectrum_u z-scores of bins 1 and 2 had sd 1.20 and 1.34 under that rule (this sum: exact sd ratio
1.25, 1.29). Lines at negative frequencies use R at |f| (exact for real coherences, e.g. Kaimal; for
complex ones the leakage weight of those lines in bins >= 1 is small).

Cost: lines within LINE_BAND Welch bins of each bin (Hann sidelobes: |c|^2 falls as bin^-6, so
the neglected part is < 1e-6 of the sum), bin pairs up to MAX_LAG bins apart (beyond, |A|^2 + |B|^2 <
1e-4 of the diagonal for a Hann window), all distinct start differences D. When that is more than
MAX_WORK products the rule-of-thumb model is used (very long records: many segments, where it is accurate).
The sums over D and over A, B do not depend on the point set, so ``node_terms`` folds them into one Gram
matrix G_m = sum_D count_D (Re a Re a^T + Im a Im a^T) per bin and ``averaged`` is sum_ij G_m,ij R_ij.
"""

from __future__ import annotations

import math

import numpy as np

from turbgen.validation.estimators import WelchSetup

LINE_BAND = 8  # Welch bins either side whose lines enter a bin's sums
MAX_LAG = 3  # covariances kept between bins up to this many bins apart
MAX_WORK = 6e7  # bins x lines x (lags x bin offsets) above which the rule-of-thumb model is used


def _hann_dtft(nu, n):
    """DTFT of the periodic Hann window at normalised frequency nu, and the Dirichlet kernel d used for it."""

    def d(x):
        zz = np.exp(-2j * np.pi * x)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = (1.0 - np.exp(-2j * np.pi * n * x)) / (1.0 - zz)  # zz^n as one exp
        return np.where(np.abs(np.sin(np.pi * x)) < 1e-12, complex(n), out)

    return 0.5 * d(nu) - 0.25 * d(nu - 1.0 / n) - 0.25 * d(nu + 1.0 / n), d


class WelchCovariance:
    """Covariance matrix (bins m, m' with |m - m'| <= MAX_LAG) of a Welch average over given segment starts.

    ``cov(lines)`` returns a dict lag d -> (nbins - d,) array Cov(P_m, P_{m+d}) of the one-point one-sided
    Welch estimate [(m^2 s^-2 Hz^-1)^2]; ``None`` when too expensive (see module docstring).
    """

    def __init__(self, setup: WelchSetup, nt: int, starts):
        self.setup, self.nt = setup, nt
        n = setup.nperseg
        self.nb = n // 2 + 1
        ratio = nt / n
        self.width = min(int(math.ceil(LINE_BAND * ratio)), (nt - 1) // 2)
        starts = np.asarray(list(starts), dtype=np.int64)
        self.k = starts.size
        diff = (starts[:, None] - starts[None, :]).ravel()
        self.lags, self.lag_count = np.unique(diff, return_counts=True)
        work = self.nb * (2 * self.width + 1) * self.lags.size * (MAX_LAG + 1) * 2
        self.feasible = self.k > 0 and work <= MAX_WORK
        if not self.feasible:
            return
        m = np.arange(self.nb)
        # q for bin m: round(m ratio) + o, o in [-width - MAX_LAG ratio, width + MAX_LAG ratio] so every
        # partner bin's lines are in the same index window
        ext = self.width + int(math.ceil(MAX_LAG * ratio))
        self.base = np.round(m * ratio).astype(np.int64)
        self.offsets = np.arange(-ext, ext + 1)
        q = self.base[:, None] + self.offsets[None, :]  # (nb, nq) extended line index
        self.q = np.mod(q, nt)
        dt = setup.dt_s
        f = q / (nt * dt)
        w_m, d = _hann_dtft(m[:, None] / n - f * dt, n)
        mean_e = d(-f * dt) / n
        w0, _ = _hann_dtft(m[:, None] / n + 0.0 * f, n)
        self.c = w_m - mean_e * w0  # (nb, nq): c_m(q), q = self.q
        self.c[self.q == 0] = 0.0
        # lines farther than ``width`` from bin m's own base carry nothing for bin m
        self.c[np.abs(q - self.base[:, None]) > self.width] = 0.0
        # c_m(nt - q) on the same index window: the partner (negative) frequency of each q
        fneg = -f
        w_mn, _ = _hann_dtft(m[:, None] / n - fneg * dt, n)
        self.cneg = w_mn - (d(-fneg * dt) / n) * w0
        self.cneg[self.q == 0] = 0.0  # (not windowed: c_m(-q) matters where -q is near bin m, i.e. m near 0 or n/2)
        self.phase = np.exp(2j * np.pi * np.outer(self.lags, q.ravel()) / nt).reshape(self.lags.size, *q.shape)

    def _lines(self, lines_half: np.ndarray) -> np.ndarray:
        """(nb, nq) line variance L of every column q of the index window."""
        nt = self.nt
        j = np.where(self.q > nt // 2, nt - self.q, self.q)
        return np.asarray(lines_half, float)[j]

    def node_terms(self, lines_half: np.ndarray, node_f: np.ndarray) -> dict | None:
        """Per-node line sums a_i of A and B (module docstring), gathered for ``averaged`` into the Gram
        matrices G_m = sum over segment lags D (weighted by their count) and over A, B of
        Re(a) Re(a)^T + Im(a) Im(a)^T, so that the covariance for any R is sum_ij G_m,ij R_ij.

        Parameters
        ----------
        lines_half : numpy.ndarray
            (nt // 2 + 1,) two-sided line variances L_j [m^2 s^-2].
        node_f : numpy.ndarray
            (nn,) increasing frequency nodes [Hz] of the correlation sums.

        Returns
        -------
        dict or None
            Lag d -> (nbins - d, nn, nn) G_m [(m^2 s^-2)^2]; None when too expensive.
        """
        if not self.feasible:
            return None
        nt = self.nt
        j = np.where(self.q > nt // 2, nt - self.q, self.q)
        hat = _log_hat_weights(j / (nt * self.setup.dt_s), node_f)  # (nb, nq, nn)
        L = self._lines(lines_half)
        sw = np.sqrt(np.tile(self.lag_count.astype(float), 2))[None, :, None]  # real and imaginary rows
        out = {}
        for lag in range(MAX_LAG + 1):
            a_rows, b_rows = slice(0, self.nb - lag), slice(lag, self.nb)
            shift = self.base[b_rows] - self.base[a_rows]
            wa = L[a_rows] * self.c[a_rows]
            gram = 0.0
            for cb in (np.conj(_shift_rows(self.c[b_rows], shift)), _shift_rows(self.cneg[b_rows], shift)):
                x = (self.phase[:, a_rows] * (wa * cb)).transpose(1, 0, 2)  # (r, l, q)
                # lines summed per node with real weights: one real BLAS product per bin on the contiguous
                # real and imaginary parts (matmul does not use BLAS on the strided views x.real, x.imag)
                y = np.matmul(np.concatenate([x.real, x.imag], axis=1), hat[a_rows]) * sw  # (r, 2 l, nn)
                gram = gram + np.matmul(y.transpose(0, 2, 1), y)
            out[lag] = gram
        return out

    def averaged(self, terms: dict | None, rho2: np.ndarray) -> dict | None:
        """Covariance of the Welch estimate averaged over a point set with two-frequency correlation sum ``rho2``.

        Parameters
        ----------
        terms : dict or None
            ``node_terms`` of the line spectrum (None: too expensive, returned as None).
        rho2 : numpy.ndarray
            (nn, nn) R(nu_i, nu_j) [-] of the point set at the nodes of ``terms`` (all ones: one point).

        Returns
        -------
        dict or None
            Lag d -> (nbins - d,) Cov(P_m, P_{m+d}) of the point average [(m^2 s^-2 Hz^-1)^2].
        """
        if terms is None:
            return None
        scale = self.setup.scale
        r = np.real(rho2)  # real: sums over ordered pairs
        # sum_D count_D (|A|^2 + |B|^2) = sum_ij a_i conj(a_j) R_ij summed = sum_ij G_ij R_ij (R symmetric)
        return {lag: np.einsum("rij,ij->r", gram, r) * scale[: self.nb - lag] * scale[lag:] / self.k**2
                for lag, gram in terms.items()}

    def cov(self, lines_half: np.ndarray) -> dict | None:
        """Covariance of the one-point Welch estimate of a line process.

        Parameters
        ----------
        lines_half : numpy.ndarray
            (nt // 2 + 1,) two-sided line variances L_j [m^2 s^-2], j = 0 .. nt // 2.

        Returns
        -------
        dict or None
            Lag d -> (nbins - d,) Cov(P_m, P_{m+d}) [(m^2 s^-2 Hz^-1)^2]; None when too expensive.
        """
        if not self.feasible:
            return None
        L = self._lines(lines_half)  # (nb, nq)
        scale = self.setup.scale
        out = {}
        for lag in range(MAX_LAG + 1):
            a_rows = slice(0, self.nb - lag)
            b_rows = slice(lag, self.nb)
            # align bin m+lag's coefficients on bin m's q window: shift by base difference
            shift = self.base[b_rows] - self.base[a_rows]
            cb = _shift_rows(self.c[b_rows], shift)
            cbn = _shift_rows(self.cneg[b_rows], shift)
            wa = L[a_rows] * self.c[a_rows]  # (r, nq)
            A = np.einsum("lrq,rq->lr", self.phase[:, a_rows], wa * np.conj(cb))
            B = np.einsum("lrq,rq->lr", self.phase[:, a_rows], wa * cbn)
            s = np.einsum("l,lr->r", self.lag_count.astype(float), np.abs(A) ** 2 + np.abs(B) ** 2)
            out[lag] = s * scale[a_rows] * scale[b_rows] / self.k**2
        return out


def _log_hat_weights(f: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Weights (f.shape + (nn,)) of linear interpolation in log f between ``nodes`` [Hz] (clipped to their
    range): sum_i w_i(f) g(nu_i) interpolates g at f as ``Theory.rho`` does; the weights sum to 1."""
    x = np.log(np.clip(f, nodes[0], nodes[-1]))
    xn = np.log(nodes)
    k = np.clip(np.searchsorted(xn, x, side="right") - 1, 0, nodes.size - 2)
    t = (x - xn[k]) / (xn[k + 1] - xn[k])
    w = np.zeros(f.shape + (nodes.size,))
    np.put_along_axis(w, k[..., None], (1.0 - t)[..., None], axis=-1)
    np.put_along_axis(w, (k + 1)[..., None], t[..., None], axis=-1)
    return w


def _shift_rows(x: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """Row r shifted right by shift[r] columns (zero fill): column o of bin m + d's row then holds line
    base_m + offset_o, as column o of bin m's row does (bases differ by shift)."""
    out = np.zeros_like(x)
    nq = x.shape[1]
    for s in np.unique(shift):
        rows = shift == s
        s = int(s)
        if s >= 0:
            out[rows, s:] = x[rows, : nq - s]
        else:
            out[rows, : nq + s] = x[rows, -s:]
    return out
