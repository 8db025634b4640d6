"""Expected one-sided Welch estimate of a periodic line process, exactly (Hann window, mean removed).

The Welch estimate of a bin is a weighted sum of the record's line (cross-)variances L_j [m^2 s^-2] (lines at
f_j = j / (nt dt)), so its expectation is exact, also where leakage and mean removal matter (Welch 1967)."""

from __future__ import annotations

import math

import numpy as np

from turbgen.validation.estimators import WelchSetup

KERNEL_BAND = 32  # Welch bins either side of a bin whose lines are summed (Hann leakage beyond < 1e-8)


class WelchKernel:
    """Expected one-sided Welch estimate of bins m = 0 .. n/2 as a weighted sum of spectral lines: a segment's windowed,
    mean-removed DFT is X_m = sum_j Z_j G_m(f_j) with G_m(f) = W(m/n - f dt) - e(f) W(m/n), W the window's DTFT and e(f)
    the segment mean of exp(i 2 pi f t); so E[P_m] = scale_m sum_j |G_m(f_j)|^2 L_j over the lines +-f_j (the line -f_j
    carries conj(L_j); G's period 1/dt folds partners near Nyquist back). Lines more than KERNEL_BAND bins away are
    ignored. ``nt``: samples of the periodic record (lines j = 0 .. nt // 2)."""

    def __init__(self, setup: WelchSetup, nt: int):
        n, dt = setup.nperseg, setup.dt_s
        self.setup, self.nt = setup, nt
        ratio = nt / n  # lines per Welch bin
        m = np.arange(n // 2 + 1)
        width = min(int(math.ceil(KERNEL_BAND * ratio)), (nt - 1) // 2)  # each line (mod nt) at most once per bin
        e = np.round(m * ratio).astype(int)[:, None] + np.arange(-width, width + 1)[None, :]  # extended line index
        e_mod = np.mod(e, nt)
        half = nt // 2
        self.conj = e_mod > half  # frequency e/(nt dt) = -(nt - e_mod)/(nt dt): the conjugate partner
        self.idx = np.where(self.conj, nt - e_mod, e_mod)
        weight = self._g(m[:, None], e / (nt * dt), n, dt)
        self.k = setup.scale[:, None] * np.abs(weight) ** 2
        self.k[self.idx == 0] = 0.0  # the mean (j = 0) is removed from every segment

    @staticmethod
    def _dirichlet(nu, n):
        z = np.exp(-2j * np.pi * nu)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = (1.0 - np.exp(-2j * np.pi * n * nu)) / (1.0 - z)  # z^n as one exp (cheaper than a complex power)
        return np.where(np.abs(np.sin(np.pi * nu)) < 1e-12, complex(n), d)

    @classmethod
    def _window_dtft(cls, nu, n):
        """DTFT of the periodic Hann window 0.5 - 0.5 cos(2 pi t / n), t = 0 .. n-1."""
        d = cls._dirichlet
        return 0.5 * d(nu, n) - 0.25 * d(nu - 1.0 / n, n) - 0.25 * d(nu + 1.0 / n, n)

    @classmethod
    def _g(cls, m, f, n, dt):
        mean_e = cls._dirichlet(-f * dt, n) / n
        return cls._window_dtft(m / n - f * dt, n) - mean_e * cls._window_dtft(m / n + 0.0 * f, n)

    def apply(self, lines: np.ndarray) -> np.ndarray:
        """(n // 2 + 1,) expected one-sided Welch (cross-)spectrum [m^2 s^-2 Hz^-1] of the two-sided line
        (cross-)variances ``lines`` (nt // 2 + 1,) [m^2 s^-2], real or complex."""
        lines = np.asarray(lines)
        vals = lines[self.idx]
        if np.iscomplexobj(lines):
            vals = np.where(self.conj, np.conj(vals), vals)
        return np.sum(self.k * vals, axis=1)


def segment_gain(m, f_hz, setup: WelchSetup) -> np.ndarray:
    """Complex gains G_m(f) [-] of Welch bins ``m`` for lines at ``f_hz`` [Hz] (any sign; broadcast): bin m of a
    segment's windowed, mean-removed DFT of exp(i 2 pi f t) (:class:`WelchKernel`)."""
    return WelchKernel._g(np.asarray(m), np.asarray(f_hz, dtype=float), setup.nperseg, setup.dt_s)
