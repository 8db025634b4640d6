"""Lidar and rotor signals from sampled line-of-sight speeds, and their Welch coherence.

u_LL (Guo et al. 2023, Eq. 28 without its stray outer factor; Guo et al. 2024, Eq. 23): the mean of v_los,i / n_i1
over the latest full scan, shifted by x_i/U (Guo et al. 2023, Sect. 5.1.1); u_RR (Guo et al. 2023, Eq. 23): u
averaged over the rotor disc at x = 0."""

from __future__ import annotations

import numpy as np

from turbgen import fft
from turbgen.errors import ParameterError
from turbgen.validation.estimators import WelchSetup, segment_starts
from turbgen.validation.point_sets import rotor_mask


def lidar_estimate(samples, U_m_s: float):
    """(arrival times [s], u_LL [m/s]) on the scan-step grid, while every beam-gate has a sample."""
    v, T = samples.v_los.astype(float), samples.time_s
    n_scan, nb, ng = v.shape
    step = float(np.median(np.diff(np.sort(T.ravel()))))
    lead = samples.gates_x_m / U_m_s  # (ng,)
    arrivals = T[:, :, None] + lead[None, None, :]  # (n_scan, nb, ng)
    a0 = arrivals[0].max()  # every beam-gate has a first sample
    a1 = arrivals[-1].min()
    grid = a0 + step * np.arange(int(np.floor((a1 - a0) / step + 1e-9)) + 1)
    est = np.zeros(grid.size)
    for b in range(nb):
        for g in range(ng):
            k = np.searchsorted(arrivals[:, b, g], grid + 1e-9, side="right") - 1
            est += v[k, b, g] / samples.n1[b, g]
    return grid, est / (nb * ng)


def rotor_average(fs, radius_m: float, t_s: np.ndarray, chunk: int | None = None) -> tuple[np.ndarray, float]:
    """u_RR [m/s] at stored times ``t_s`` [s] and TI_R [-] (Schlipf et al. 2020, Eq. 3) of the disc at x = 0;
    ParameterError without a plane x = 0."""
    g = fs.grid
    xs = g.x()
    if not np.any(np.abs(xs) < 1e-9):
        raise ParameterError(f"the store has no rotor plane x = 0 (planes: {', '.join(f'{v:g}' for v in xs)} m)")
    ix = int(np.argmin(np.abs(xs)))
    mask = rotor_mask(g, radius_m)
    chunk = chunk or fs.chunk_t
    series = np.empty(g.nt)
    s1 = s2 = 0.0
    for t0 in range(0, g.nt, chunk):  # checked reads: a corrupted chunk, NaN or an implausible value is refused
        block = np.asarray(fs.read_span("u", ix, t0, min(t0 + chunk, g.nt)), dtype=np.float64)[:, mask]
        series[t0 : t0 + block.shape[0]] = block.mean(axis=1)
        s1 = s1 + block.sum(axis=0)
        s2 = s2 + (block**2).sum(axis=0)
    var = np.maximum(s2 / g.nt - (s1 / g.nt) ** 2, 0.0)
    return np.interp(t_s, g.t(), series), float(np.mean(np.sqrt(var)) / fs.U_m_s)


def lidar_ti(samples, U_m_s: float) -> float:
    """Uncorrected lidar TI [-]: mean over beams and gates of sigma(v_los / n1) / U (Schlipf et al. 2020, Eq. 3,
    without the c_TI correction of their Eq. 8)."""
    v = samples.v_los.astype(float) / samples.n1[None]
    return float(np.mean(v.std(axis=0)) / U_m_s)


def welch_rl(u_ll: np.ndarray, u_rr: np.ndarray, setup: WelchSetup) -> dict:
    """Welch spectra of u_LL and u_RR [m/s] with the Hann window of ``setup``, segment means removed: ``f_hz``,
    ``S_LL``, ``S_RR`` [m^2 s^-2 Hz^-1], ``S_RL``, ``coh2_RL``, ``G_RL`` = |S_RL| / S_LL, ``n_segments``, ``n_eff``,
    ``setup``. ParameterError for fewer than two segments."""
    starts = segment_starts(u_ll.size, setup)
    if len(starts) < 2:
        raise ParameterError(f"lidar signal of {u_ll.size} samples is too short for segments of {setup.nperseg}")

    def transforms(u):  # of all segments in one batch
        x = np.stack([u[s : s + setup.nperseg] for s in starts])
        return fft.oneshot().rfft((x - x.mean(axis=1, keepdims=True)) * setup.window, axis=-1)

    A, B = transforms(u_ll), transforms(u_rr)
    sll, srr, srl = (np.abs(A) ** 2).sum(axis=0), (np.abs(B) ** 2).sum(axis=0), (B * np.conj(A)).sum(axis=0)
    k = len(starts)
    scale = setup.scale / k
    sll, srr, srl = sll * scale, srr * scale, srl * scale
    with np.errstate(divide="ignore", invalid="ignore"):
        coh2 = np.abs(srl) ** 2 / (sll * srr)
        gain = np.abs(srl) / sll
    return {"f_hz": setup.freqs, "S_LL": sll, "S_RR": srr, "S_RL": srl, "coh2_RL": coh2, "G_RL": gain,
            "n_segments": k, "n_eff": setup.effective_segments(k, k - 1), "setup": setup}
