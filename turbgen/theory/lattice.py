"""Geometry of the periodic record and box that both generators synthesise and the validator sums over.

A record of nt samples spaced dt [s] is a sum of spectral *lines* at f_j = j / (nt dt), j = 0 .. nt/2
(a real field: the lines -f_j are the complex conjugates). The Mann box is periodic in y and z as well:
nyp x nzp points spaced dy, dz [m], whose wavenumbers form a lattice in FFT order (Mann 1998, Sec. 2).
These facts are shared by turbgen.synthesis (which synthesises on them) and turbgen.validate (which
predicts the synthesised field's statistics on them); the quadrature of the cells near the k1 axis is
not here: synthesis and validate compute it with deliberately separate rules.
"""

from __future__ import annotations

import numpy as np

from turbgen import fft


def line_frequencies(nt: int, dt_s: float) -> np.ndarray:
    """Frequencies of the record's spectral lines.

    Parameters
    ----------
    nt : int
        Samples of the periodic record.
    dt_s : float
        Sampling interval [s].

    Returns
    -------
    numpy.ndarray
        (nt // 2 + 1,) f_j = j / (nt dt) [Hz], j = 0 .. nt // 2 (the rfft bins).
    """
    return np.arange(nt // 2 + 1) / (nt * dt_s)


def line_bands(nt: int, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Edges of the band each line stands for (whose variance a generator gives it), lines j = 0 .. nt // 2.

    Parameters
    ----------
    nt, dt_s : int, float
        As :func:`line_frequencies`.

    Returns
    -------
    tuple of numpy.ndarray
        (lo, hi) [Hz]: [(j - 1/2) df, (j + 1/2) df] clipped to [0, 1/(2 dt)], df = 1 / (nt dt).
    """
    df = 1.0 / (nt * dt_s)
    j = np.arange(nt // 2 + 1)
    return np.maximum(j - 0.5, 0.0) * df, np.minimum((j + 0.5) * df, 0.5 / dt_s)


def pair_weights(nt: int) -> np.ndarray:
    """Weight of each line j = 0 .. nt // 2 in a sum over the full (two-sided) spectrum.

    Parameters
    ----------
    nt : int
        Samples of the periodic record.

    Returns
    -------
    numpy.ndarray
        (nt // 2 + 1,) weights [-]: 2 (the lines +-f_j together), 1 for j = 0 and for the single
        Nyquist line of an even nt.
    """
    w = np.full(nt // 2 + 1, 2.0)
    w[0] = 1.0
    if nt % 2 == 0:
        w[-1] = 1.0
    return w


def k2_wavenumbers(nyp: int, dy_m: float) -> np.ndarray:
    """Lateral wavenumbers of a periodic box of nyp points spaced dy_m [m].

    Parameters
    ----------
    nyp : int
        Points of the periodic box in y.
    dy_m : float
        Lateral spacing [m].

    Returns
    -------
    numpy.ndarray
        (nyp,) k2 [rad/m] in FFT order: j dk2 for j <= nyp // 2 (the Nyquist row stored positive, as
        synthesised), else (j - nyp) dk2, with dk2 = 2 pi / (nyp dy).
    """
    j = np.arange(nyp)
    return np.where(j <= nyp // 2, j, j - nyp) * (2 * np.pi / (nyp * dy_m))


def k3_wavenumbers(nzp: int, dz_m: float) -> np.ndarray:
    """Vertical wavenumbers of a periodic box of nzp points spaced dz_m [m].

    Parameters
    ----------
    nzp : int
        Points of the periodic box in z.
    dz_m : float
        Vertical spacing [m].

    Returns
    -------
    numpy.ndarray
        (nzp,) k3 [rad/m] in numpy ``fftfreq`` order (the Nyquist column negative for even nzp).
    """
    return fft.fftfreq(nzp, d=dz_m) * 2 * np.pi
