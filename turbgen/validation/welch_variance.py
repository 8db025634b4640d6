"""Exact covariance of Welch estimates of an nt-periodic Gaussian line process (short records).

The record is a sum of lines q = 0 .. nt-1 (frequency q / (nt dt), q > nt/2 negative) with independent circular Gaussian
amplitudes Y_q, E|Y_q|^2 = L_q, Y_{nt-q} = conj(Y_q). A segment starting at sample t0 has the windowed, mean-removed DFT
X_{t0, m} = sum_q Y_q c_m(q) exp(i 2 pi q t0 / nt), c_m(q) = G_m(q / (nt dt)) (``segment_gain``), so by Isserlis

    Cov(|X_{s,m}|^2, |X_{s',m'}|^2) = |A|^2 + |B|^2,
    A = sum_q L_q c_m(q) conj(c_m'(q)) e^{i 2 pi q D / nt},   B = sum_q L_q c_m(q) c_m'(nt - q) e^{i 2 pi q D / nt},

D = t0_s - t0_s'. Summed over all segment pairs this is the exact variance of the Welch average (actual segment
starts, overlap with a coloured spectrum, mean removal, neighbouring bins: what the K_eff rule of thumb leaves out).

Averages over N points/planes (``averaged``): the covariance of the average, (1 / N^2) sum_pq (|A_pq|^2 + |B_pq|^2),
is sum_ij a_i conj(a_j) R(nu_i, nu_j) (same for B), with coh_pq(f) interpolated linearly in log f between frequency
nodes nu_i, a_i the line sums of A weighted by node i's interpolation weight, and R the two-frequency correlation sum
of the point set (``Theory.rho_*``; several nodes per bin: the lowest bins collect more coherent lines by leakage).
Negative-frequency lines use R at |f|. Above MAX_WORK the rule of thumb is used (long records, where it is accurate)."""

from __future__ import annotations

import math

import numpy as np

from turbgen.validation.estimators import WelchSetup
from turbgen.validation.welch_kernel import segment_gain

LINE_BAND = 8  # Welch bins either side whose lines enter a bin's sums
MAX_LAG = 3  # covariances kept between bins up to this many bins apart
MAX_WORK = 6e7  # bins x lines x (lags x bin offsets) above which the rule-of-thumb model is used


class WelchCovariance:
    """Covariance (bins m, m' with |m - m'| <= MAX_LAG) of a Welch average over the segment ``starts`` of a record of
    ``nt`` samples; ``feasible`` False when too expensive (module docstring)."""

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
        self.j = np.where(self.q > nt // 2, nt - self.q, self.q)  # line j <= nt // 2 of each column
        f = q / (nt * setup.dt_s)
        self.c = segment_gain(m[:, None], f, setup)  # (nb, nq): c_m(q), q = self.q
        self.c[self.q == 0] = 0.0
        # lines farther than ``width`` from bin m's own base carry nothing for bin m
        self.c[np.abs(q - self.base[:, None]) > self.width] = 0.0
        # c_m(nt - q) on the same index window: the partner (negative) frequency of each q
        self.cneg = segment_gain(m[:, None], -f, setup)
        self.cneg[self.q == 0] = 0.0  # (not windowed: c_m(-q) matters where -q is near bin m, i.e. m near 0 or n/2)
        self.phase = np.exp(2j * np.pi * np.outer(self.lags, q.ravel()) / nt).reshape(self.lags.size, *q.shape)

    def node_terms(self, lines_half: np.ndarray, node_f: np.ndarray) -> dict | None:
        """Lag d -> (nbins - d, nn, nn) Gram matrices G_m [(m^2 s^-2)^2] such that the covariance for any R is
        sum_ij G_m,ij R_ij (None when too expensive), from the line variances ``lines_half`` (nt // 2 + 1,) [m^2 s^-2]
        and the increasing frequency nodes ``node_f`` (nn,) [Hz]."""
        if not self.feasible:
            return None
        hat = _log_hat_weights(self.j / (self.nt * self.setup.dt_s), node_f)  # (nb, nq, nn)
        L = np.asarray(lines_half, float)[self.j]  # (nb, nq) line variance of every column q of the index window
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
        """Lag d -> (nbins - d,) Cov(P_m, P_{m+d}) [(m^2 s^-2 Hz^-1)^2] of the Welch estimate averaged over a point
        set with correlation sums ``rho2`` (nn, nn) [-] (all ones: one point); ``terms`` from :meth:`node_terms`."""
        if terms is None:
            return None
        scale = self.setup.scale
        r = np.real(rho2)  # real: sums over ordered pairs
        # sum_D count_D (|A|^2 + |B|^2) = sum_ij a_i conj(a_j) R_ij summed = sum_ij G_ij R_ij (R symmetric)
        return {lag: np.einsum("rij,ij->r", gram, r) * scale[: self.nb - lag] * scale[lag:] / self.k**2
                for lag, gram in terms.items()}

    def cov(self, lines_half: np.ndarray) -> dict | None:
        """Lag d -> (nbins - d,) Cov(P_m, P_{m+d}) [(m^2 s^-2 Hz^-1)^2] of the one-point Welch estimate of the line
        variances ``lines_half`` (nt // 2 + 1,) [m^2 s^-2]; None when too expensive."""
        if not self.feasible:
            return None
        L = np.asarray(lines_half, float)[self.j]  # (nb, nq)
        scale = self.setup.scale
        out = {}
        for lag in range(MAX_LAG + 1):
            a_rows, b_rows = slice(0, self.nb - lag), slice(lag, self.nb)
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
    """Weights (f.shape + (nn,)) of linear interpolation in log f between ``nodes`` [Hz] (clipped to their range), as
    ``Theory.rho`` interpolates; they sum to 1."""
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
