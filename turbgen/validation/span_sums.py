"""The sums one validator task takes over one plane and one span of time (``estimators``), from one float32
FFT per Welch segment and component."""

from __future__ import annotations

import numpy as np

from turbgen import fft

COMPONENTS = ("u", "v", "w")


def span_sums(data: dict, window: np.ndarray, starts, seps, mask: np.ndarray, iy: np.ndarray, iz: np.ndarray) -> dict:
    """Moment and Welch sums of one plane over one span of ``data`` (component -> float32 (t, ny, nz) [m/s]): ``sum``,
    ``sum2``, ``rews`` and the unscaled Welch sums ``auto``, ``yz``, ``uw``, ``sub``."""
    from turbgen.validation.welch_sums import cross_sum, point_moments, spectrum_sums, window_segment

    out = {"sum": {}, "sum2": {}}
    n = window.size
    hop = n // 2
    mask_index = np.flatnonzero(mask)
    blocks = {}  # sums over blocks of hop samples: the segments (starts on multiples of hop) are 2 blocks if n = 2 hop
    for c, d in data.items():
        out["sum"][c], out["sum2"][c], blocks[c], masked = point_moments(d, mask_index, hop)
        if c == "u":
            out["rews"] = masked
    w = window.astype(np.float32)
    nf = n // 2 + 1
    ny, nz = data["u"].shape[1:]
    sep_a = np.array([a for a, _ in seps], np.int64)
    sep_b = np.array([b for _, b in seps], np.int64)
    total = {c: np.zeros(nf) for c in COMPONENTS}  # sums over segments and points of |X|^2
    part_a = {c: np.zeros((len(seps), nf)) for c in COMPONENTS}  # ... over the first points of each separation
    part_b = {c: np.zeros((len(seps), nf)) for c in COMPONENTS}  # ... over the second points
    cross = {c: np.zeros((len(seps), nf, 2)) for c in COMPONENTS}
    uw = np.zeros((nf, 2))
    sub = []
    # reused: (segment - its mean) * window in the rows y < ny; the spare row ny keeps the FFT's stride along t off
    # multiples of 4 KiB (cache-set conflicts on power-of-two planes); the same bits.
    seg_buf = np.zeros((n, ny + 1, nz), np.float32)
    for s in starts:
        spec = {}
        for c in COMPONENTS:
            if n == 2 * hop and s % hop == 0:
                mean = ((blocks[c][s // hop] + blocks[c][s // hop + 1]) / n).astype(np.float32)
            else:
                mean = data[c][s : s + n].mean(axis=0, dtype=np.float64).astype(np.float32)
            window_segment(data[c], s, w, mean, seg_buf)
            x = fft.oneshot().rfft(seg_buf, axis=0, workers=1)  # (nf, ny + 1, nz): row ny is never read
            spec[c] = x
            spectrum_sums(x.view(np.float32), ny, sep_a, sep_b, total[c], part_a[c], part_b[c], cross[c])
        cross_sum(spec["u"].view(np.float32), spec["w"].view(np.float32), ny, uw)
        sub.append(spec["u"][:, iy][:, :, iz].reshape(nf, -1))
    out["auto"] = total
    out["yz"] = {
        c: {s: [cross[c][k, :, 0] + 1j * cross[c][k, :, 1], part_a[c][k], part_b[c][k]] for k, s in enumerate(seps)}
        for c in COMPONENTS
    }
    out["uw"] = uw[:, 0] + 1j * uw[:, 1]
    out["sub"] = np.stack(sub) if sub else np.zeros((0, nf, iy.size * iz.size), np.complex64)
    return out
