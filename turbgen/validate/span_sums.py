"""The sums one validator task takes over one plane and one span of time (``estimators``).

Every Welch segment's spectra are computed once per component and feed all the sums: the one-point
periodograms |X|^2 are accumulated per point over the segments (float64) and summed over the point
sets of every yz separation once, at the end of the span; the cross-products conj(X_p) X_{p+d} of
each separation and the u-w cross-products are dot products along z (complex64, BLAS) added over y
in complex128, so their rounding is that of 64-term float32 sums, not of whole-plane float32 sums.
"""

from __future__ import annotations

import numpy as np
import scipy.fft

COMPONENTS = ("u", "v", "w")
MOMENT_BLOCK = 64  # time steps per float32 block of the sum of squares (no float64 copy of a span)


def pair_sum(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """sum over the two yz axes of conj(a) b, per frequency (complex128): float32 dot products along z,
    added over y in complex128."""
    return np.vecdot(a, b).sum(axis=1, dtype=np.complex128)


def _moments(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-point sum and sum of squares over time of a float32 span (t, y, z), float64."""
    s2 = np.zeros(d.shape[1:])
    for b in range(0, d.shape[0], MOMENT_BLOCK):  # float32 products in small blocks, float64 sums
        blk = d[b : b + MOMENT_BLOCK]
        s2 += np.einsum("tij,tij->ij", blk, blk)
    return d.sum(axis=0, dtype=np.float64), s2


def span_sums(data: dict, window: np.ndarray, starts, seps, mask: np.ndarray, iy: np.ndarray, iz: np.ndarray) -> dict:
    """Moment and Welch sums of one plane over one span.

    Parameters
    ----------
    data : dict
        Component -> float32 (t, ny, nz) velocities [m/s] of the span.
    window : numpy.ndarray
        (nperseg,) Welch window (mean removed per segment).
    starts : iterable of int
        Start samples of the segments in the span.
    seps : sequence of (int, int)
        yz separations (a, b) in grid steps.
    mask : numpy.ndarray
        (ny, nz) bool, the rotor points (rotor-effective wind speed).
    iy, iz : numpy.ndarray
        Grid indices of the sub-lattice whose spectra are kept for the plane pairs.

    Returns
    -------
    dict
        ``sum``, ``sum2`` (component -> (ny, nz) [m/s], [m^2 s^-2] summed over t); ``rews`` (t,) [m/s];
        unscaled Welch sums over segments and points [m^2 s^-2 s^2]: ``auto`` (component -> (nf,)),
        ``yz`` (component -> {(a, b): [cross (nf,) complex, A (nf,), B (nf,)]}), ``uw`` (nf,) complex;
        ``sub`` (segments, nf, sub-lattice points) complex64 spectra of u.
    """
    out = {"sum": {}, "sum2": {}}
    for c, d in data.items():
        out["sum"][c], out["sum2"][c] = _moments(d)
    out["rews"] = data["u"][:, mask].mean(axis=1, dtype=np.float64)
    n = window.size
    w = window.astype(np.float32)[:, None, None]
    nf = n // 2 + 1
    ny, nz = data["u"].shape[1:]
    power = {c: np.zeros((nf, ny, nz)) for c in COMPONENTS}  # sum over segments of |X|^2 per point
    cross = {c: {s: np.zeros(nf, complex) for s in seps} for c in COMPONENTS}
    uw = np.zeros(nf, complex)
    sub = []
    seg_buf = np.empty((n, ny, nz), np.float32)  # reused: (segment - its mean) * window
    p_buf, sq_buf = np.empty((nf, ny, nz), np.float32), np.empty((nf, ny, 2 * nz), np.float32)
    for s in starts:
        spec = {}
        for c in COMPONENTS:
            seg = data[c][s : s + n]
            np.multiply(np.subtract(seg, seg.mean(axis=0), out=seg_buf), w, out=seg_buf)
            x = scipy.fft.rfft(seg_buf, axis=0, workers=1)
            spec[c] = x
            xv = x.view(np.float32)  # (nf, ny, 2 nz): re, im interleaved
            np.multiply(xv, xv, out=sq_buf)
            np.add(sq_buf[..., 0::2], sq_buf[..., 1::2], out=p_buf)  # |X|^2 = re^2 + im^2 in float32
            power[c] += p_buf  # summed over segments in float64
            for a, b in seps:
                cross[c][(a, b)] += pair_sum(x[:, : ny - a, : nz - b], x[:, a:, b:])
        uw += pair_sum(spec["u"], spec["w"])
        sub.append(spec["u"][:, iy][:, :, iz].reshape(nf, -1))
    out["auto"] = {c: power[c].sum(axis=(1, 2)) for c in COMPONENTS}
    out["yz"] = {
        c: {(a, b): [cross[c][(a, b)], power[c][:, : ny - a, : nz - b].sum(axis=(1, 2)),
                     power[c][:, a:, b:].sum(axis=(1, 2))] for a, b in seps}
        for c in COMPONENTS
    }
    out["uw"] = uw
    out["sub"] = np.stack(sub) if sub else np.zeros((0, nf, iy.size * iz.size), np.complex64)
    return out
