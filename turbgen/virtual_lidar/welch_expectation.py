"""The expected Welch estimates of u_RR and u_LL spectra on a periodic record: what the estimator targets.

The record is periodic, so the signals are lines at f_j = j / T of variance S(f_j) / (2 T); bin m weights them by
|G_m(+-f_j)|^2 of the Hann window with mean removal (Welch 1967). This accounts for the main lobe mixing
coherences near the lowest bins."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from turbgen.theory.lidar_preview import PreviewSpectra
from turbgen.validation.estimators import WelchSetup, segment_starts
from turbgen.validation.welch_kernel import segment_gain

BAND_BINS = 6  # lines up to this many bins beyond the last bin (Hann leakage power beyond < 1e-5 of the lobe)


def theory_nodes(f_bins_hz, setup: WelchSetup, record_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, lines) [Hz]: where the theory is evaluated (every line below bin 2, then the bin centres), and the
    record's lines j / T (period ``record_s`` [s]) up to BAND_BINS bins beyond the last of ``f_bins_hz``."""
    df = 1.0 / (setup.nperseg * setup.dt_s)
    top = int(np.rint(np.max(f_bins_hz) / df)) + BAND_BINS
    lines = np.arange(1, int(math.floor(top * df * record_s + 1e-9)) + 1) / record_s
    low = lines[lines < 2.0 * df * (1 - 1e-9)]
    nodes = np.concatenate([low, df * np.arange(2, top + 1)])
    return (lines if nodes.size >= lines.size else nodes), lines


def weigh_lines(S_RR, S_LL, S_RL, lines_hz, f_bins_hz, setup: WelchSetup, record_s: float) -> tuple:
    """Expected one-sided Welch S_RR, S_LL (real), S_RL (complex) [m^2 s^-2 Hz^-1] at ``f_bins_hz`` of the spectra
    given at the record's lines ``lines_hz`` = j / T, j >= 1 (the mean is removed from every segment)."""
    lines = np.asarray(lines_hz, dtype=float)
    m = np.rint(np.asarray(f_bins_hz, dtype=float) * setup.nperseg * setup.dt_s).astype(int)
    w_pos = np.abs(segment_gain(m[:, None], lines[None, :], setup)) ** 2
    w_neg = np.abs(segment_gain(m[:, None], -lines[None, :], setup)) ** 2
    scale = setup.scale[m] / (2.0 * record_s)  # one-sided S(f_j) -> line variance S / (2 T)
    rl = np.asarray(S_RL, dtype=complex)
    return (scale * ((w_pos + w_neg) @ np.asarray(S_RR, dtype=float)),
            scale * ((w_pos + w_neg) @ np.asarray(S_LL, dtype=float)),
            scale * (w_pos @ rl + w_neg @ np.conj(rl)))


@dataclass(frozen=True)
class ExpectedWelch(PreviewSpectra):
    """Expected one-sided Welch S_RR, S_LL, S_RL at the bins (:class:`PreviewSpectra`) and, if asked for, the
    equivalent independent segments ``n_eff`` [-] of one record's gamma^2_RL per bin (:func:`effective_segments`)."""

    n_eff: np.ndarray | None = None


def expected_welch(spectra: PreviewSpectra, f_bins_hz, setup: WelchSetup, record_s: float,
                   n_samples: int | None = None) -> ExpectedWelch:
    """Expected Welch S_RR, S_LL, S_RL [m^2 s^-2 Hz^-1] at ``f_bins_hz`` for a record of ``record_s`` [s]; their
    coh2_RL, G_RL are what the Welch estimates target; ``n_samples`` adds :func:`effective_segments`."""
    f_bins = np.asarray(f_bins_hz, dtype=float)
    nodes, lines = theory_nodes(f_bins, setup, record_s)
    if nodes.size == lines.size:
        rr, ll, rl = spectra.S_RR, spectra.S_LL, spectra.S_RL
    else:
        x, xl = np.log(spectra.f_hz), np.log(lines)
        rr = np.exp(CubicSpline(x, np.log(spectra.S_RR))(xl))
        ll = np.exp(CubicSpline(x, np.log(spectra.S_LL))(xl))
        c = spectra.S_RL / np.sqrt(spectra.S_RR * spectra.S_LL)
        rl = (CubicSpline(x, c.real)(xl) + 1j * CubicSpline(x, c.imag)(xl)) * np.sqrt(rr * ll)
    n_eff = None if n_samples is None else effective_segments(rr, ll, lines, f_bins, setup, n_samples)
    return ExpectedWelch(f_bins, *weigh_lines(rr, ll, rl, lines, f_bins, setup, record_s), n_eff=n_eff)


def effective_segments(S_RR, S_LL, lines_hz, f_bins_hz, setup: WelchSetup, n_samples: int) -> np.ndarray:
    """Equivalent number of independent segments [-] of the Welch gamma^2_RL of one record, per bin: n = E[P]^2 / Var[P]
    of each Welch estimate over the actual segment starts (exact for Gaussian lines, Isserlis); unlike
    ``WelchSetup.effective_segments`` (Welch 1967) it holds where the spectrum is steep across the window's lobe.
    Returns sqrt(n_RR n_LL), the n of Goodman's law; independent records add theirs."""
    lines = np.asarray(lines_hz, dtype=float)
    m = np.rint(np.asarray(f_bins_hz, dtype=float) * setup.nperseg * setup.dt_s).astype(int)
    starts = np.asarray(list(segment_starts(n_samples, setup)), dtype=float)
    lags, count = np.unique(starts[:, None] - starts[None, :], return_counts=True)
    # lines within BAND_BINS bins of each bin: a fixed window of line indices around the bin
    width = int(math.ceil(BAND_BINS * (lines.size - 1) / (lines[-1] - lines[0]) / (setup.nperseg * setup.dt_s)))
    idx = np.searchsorted(lines, m / (setup.nperseg * setup.dt_s))[:, None] + np.arange(-width, width + 1)
    valid = (idx >= 0) & (idx < lines.size)
    f = lines[np.clip(idx, 0, lines.size - 1)]
    g_pos, g_neg = segment_gain(m[:, None], f, setup), segment_gain(m[:, None], -f, setup)
    n = []
    for S in (S_RR, S_LL):
        L = np.where(valid, np.asarray(S, dtype=float)[np.clip(idx, 0, lines.size - 1)], 0.0)
        a_pos, a_neg, b = L * np.abs(g_pos) ** 2, L * np.abs(g_neg) ** 2, L * g_pos * g_neg
        var = np.zeros(m.size)
        for lag, c in zip(lags * setup.dt_s, count):
            e = np.exp(2j * np.pi * f * lag)
            A = np.sum(a_pos * e + a_neg * np.conj(e), axis=1)
            B = np.sum(b * 2.0 * e.real, axis=1)
            var += c * (np.abs(A) ** 2 + np.abs(B) ** 2)
        n.append((starts.size * np.sum(a_pos + a_neg, axis=1)) ** 2 / var)
    return np.sqrt(n[0] * n[1])
