"""Geometry of the periodic record and box that both generators synthesise and the validator sums over.

A record of nt samples spaced dt [s] is a sum of spectral *lines* at f_j = j / (nt dt), j = 0 .. nt/2;
the Mann box is periodic in y and z as well, its wavenumbers a lattice in FFT order (Mann 1998, Sec. 2).
:func:`cell_rule` integrates a lattice cell; each user (synthesis, validation, lidar preview) chooses
its own nodes and grading, so the three integrate the cells near the k1 axis with independent rules and
an error in one shows as a disagreement."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from turbgen import fft


def line_frequencies(nt: int, dt_s: float) -> np.ndarray:
    """(nt // 2 + 1,) frequencies f_j = j / (nt dt) [Hz] of the record's lines (the rfft bins), ``dt_s`` [s]."""
    return np.arange(nt // 2 + 1) / (nt * dt_s)


def line_bands(nt: int, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) [Hz]: the band each line j stands for (whose variance a generator gives it):
    [(j - 1/2) df, (j + 1/2) df] clipped to [0, 1/(2 dt)], df = 1 / (nt dt); arguments as :func:`line_frequencies`."""
    df = 1.0 / (nt * dt_s)
    j = np.arange(nt // 2 + 1)
    return np.maximum(j - 0.5, 0.0) * df, np.minimum((j + 0.5) * df, 0.5 / dt_s)


def pair_weights(nt: int) -> np.ndarray:
    """(nt // 2 + 1,) weights [-] of the lines in a sum over the two-sided spectrum: 2 (the lines +-f_j together), 1 for
    j = 0 and for the single Nyquist line of an even nt."""
    w = np.full(nt // 2 + 1, 2.0)
    w[0] = 1.0
    if nt % 2 == 0:
        w[-1] = 1.0
    return w


def k2_wavenumbers(nyp: int, dy_m: float) -> np.ndarray:
    """(nyp,) lateral wavenumbers k2 [rad/m] of a periodic box of nyp points spaced ``dy_m`` [m], in FFT order: j dk2
    for j <= nyp // 2 (the Nyquist row positive, as synthesised), else (j - nyp) dk2; dk2 = 2 pi / (nyp dy)."""
    j = np.arange(nyp)
    return np.where(j <= nyp // 2, j, j - nyp) * (2 * np.pi / (nyp * dy_m))


def k3_wavenumbers(nzp: int, dz_m: float) -> np.ndarray:
    """(nzp,) vertical wavenumbers k3 [rad/m] of nzp points spaced ``dz_m`` [m], ``fftfreq`` order."""
    return fft.fftfreq(nzp, d=dz_m) * 2 * np.pi


@lru_cache(maxsize=8)
def _legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.polynomial.legendre.leggauss(n)


def gauss_panel(a: float, b: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of the n-point Gauss-Legendre rule on [a, b]."""
    x, w = _legendre(n)
    return 0.5 * (b - a) * x + 0.5 * (a + b), 0.5 * (b - a) * w


def cell_rule(center: float, width: float, n: int, floor: float, ratio: float, max_panels: int):
    """Gauss-Legendre nodes and weights [rad/m] over the cell [center - width/2, center + width/2] [rad/m], ``n``
    per panel; a cell centred on 0 (where Phi peaks on the k1 axis) is split on each side into panels shrinking by
    ``ratio`` towards 0 while the innermost is wider than ``floor`` [rad/m] (at most ``max_panels``)."""
    if center != 0.0:
        return gauss_panel(center - width / 2, center + width / 2, n)
    edges = [width / 2]
    while edges[-1] > floor and len(edges) < max_panels:
        edges.append(edges[-1] / ratio)
    edges = np.array([0.0, *edges[::-1]])
    parts = [gauss_panel(a, b, n) for a, b in zip(edges[:-1], edges[1:])]
    x = np.concatenate([p[0] for p in parts])
    w = np.concatenate([p[1] for p in parts])
    return np.concatenate([-x[::-1], x]), np.concatenate([w[::-1], w])
