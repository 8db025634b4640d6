"""User spectra of the Kaimal-type generator: a site's u, v, w spectra in place of the Kaimal form.

The generator gives line k of the record (f_k = k df, df = 1 / (nt dt); turbgen.theory.lattice) the
variance of its band [f_k - df/2, f_k + df/2], as it does with the Kaimal spectrum (Guo et al. 2023,
Eq. 11) integrated in closed form. So a user spectrum becomes the mean one-sided PSD S_k [m^2/s] of each
band k >= 1: a callable's density averaged over the band by Gauss-Legendre quadrature, or a table of band
means (a Welch-averaged measurement) interpolated linearly at f_k. A run records :class:`LineSpectrum` in
its store, so a re-run and the validator need neither the callable nor the file."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError
from turbgen.theory.lattice import line_bands, line_frequencies

COLUMNS = ("f_hz", "S_u", "S_v", "S_w")
GAUSS_NODES = 16  # nodes per band of a callable's quadrature: error ~ rho^(-2 n) for a pole rho band half-widths away
# how far [df] the ends of a table may fall short of the run's lowest and highest lines (digits lost in a file)
COVER_SLACK = 1e-6


def _check_values(name: str, f_hz: np.ndarray, values: np.ndarray) -> None:
    """ParameterError naming the first non-finite or negative PSD value."""
    bad = ~np.isfinite(values) | (values < 0)
    if bad.any():
        c, j = np.argwhere(bad)[0]
        raise ParameterError(f"{name}: {COLUMNS[1 + c]} = {float(values[c, j])!r} at f = {f_hz[j]:g} Hz; a PSD "
                             "[m^2/s] must be finite and >= 0")


@dataclass(frozen=True)
class LineSpectrum:
    """Band-mean one-sided PSDs (3, nt // 2) S_k [m^2/s] of u, v, w on a run's lines f_k = k / (nt dt), k = 1 ..
    nt // 2 (``nt`` samples ``dt_s`` [s] apart)."""

    nt: int
    dt_s: float
    S_m2_s: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]

    def __post_init__(self):
        values = np.asarray(self.S_m2_s, dtype=float)
        if values.shape != (3, self.nt // 2):
            raise ParameterError(f"spectrum: {values.shape} band means for {self.nt // 2} lines; needs (3, "
                                 f"{self.nt // 2}) (u, v, w at f_k = k / (nt dt), k = 1 .. nt // 2)")
        _check_values("spectrum", self.f_hz, values)

    @property
    def f_hz(self) -> np.ndarray:
        """The lines f_k [Hz], k = 1 .. nt // 2."""
        return line_frequencies(self.nt, self.dt_s)[1:]

    def __call__(self, f_hz) -> np.ndarray:
        """(3, n) PSDs [m^2/s] at ``f_hz`` [Hz]: the band means interpolated linearly (held beyond the lines), exactly
        the band mean on a line (what the preview theory of a lidar on the store reads)."""
        return np.array([np.interp(f_hz, self.f_hz, row) for row in self.S_m2_s])

    def line_variances(self) -> np.ndarray:
        """Variance of each line's band [m^2 s^-2], (3, nt // 2 + 1), line 0 (the mean) zero."""
        lo, hi = line_bands(self.nt, self.dt_s)
        out = np.zeros((3, lo.size))
        out[:, 1:] = np.asarray(self.S_m2_s, dtype=float) * (hi - lo)[1:]
        return out

    def to_table(self) -> dict:
        """The store's record: ``f_hz`` [Hz], ``S_u``, ``S_v``, ``S_w`` [m^2/s] as lists, for :meth:`from_table`."""
        return {"f_hz": self.f_hz.tolist(), **{c: list(s) for c, s in zip(COLUMNS[1:], self.S_m2_s)}}

    @classmethod
    def from_values(cls, nt: int, dt_s: float, values) -> "LineSpectrum":
        """The spectrum of band means ``values`` (3, nt // 2) [m^2/s]."""
        values = np.asarray(values, dtype=float)
        return cls(nt, float(dt_s), tuple(tuple(row) for row in values.tolist()))

    @classmethod
    def from_callable(cls, S: Callable, nt: int, dt_s: float) -> "LineSpectrum":
        """Band means of the density ``S(f_hz) -> (3, n)`` [m^2/s] over each line's band (Gauss-Legendre, GAUSS_NODES).

        ``S`` is called once, on frequencies > 0 [Hz]; ParameterError unless it returns (3, n) finite values >= 0."""
        lo, hi = (edge[1:] for edge in line_bands(nt, dt_s))
        x, w = np.polynomial.legendre.leggauss(GAUSS_NODES)
        nodes = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * x[None, :]
        try:
            values = np.asarray(S(nodes.ravel()), dtype=float)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"spectrum: the callable failed on {nodes.size} frequencies [Hz]: {exc}") from None
        if values.shape != (3, nodes.size):
            raise ParameterError(f"spectrum: the callable returned shape {values.shape} for {nodes.size} "
                                 f"frequencies; needs (3, {nodes.size}) (S_u, S_v, S_w [m^2/s])")
        _check_values("spectrum (callable)", nodes.ravel(), values)
        values = values.reshape(3, *nodes.shape)
        mean = np.zeros((3, lo.size))
        for i in range(GAUSS_NODES):  # one fixed order of the sum: the same bits on every machine
            mean += (0.5 * w[i]) * values[:, :, i]
        return cls.from_values(nt, dt_s, mean)

    @classmethod
    def from_table(cls, f_hz, S_m2_s, nt: int, dt_s: float) -> "LineSpectrum":
        """Band means at the run's lines, interpolated linearly in a table of band means (exact on the lines):
        (n,) increasing ``f_hz`` [Hz] covering df = 1/(nt dt) to nt // 2 df, (3, n) S_u, S_v, S_w [m^2/s] >= 0.
        ParameterError for a wrong shape, bad values, frequencies not increasing or not covering the lines."""
        f = np.asarray(f_hz, dtype=float)
        S = np.asarray(S_m2_s, dtype=float)
        if f.ndim != 1 or f.size < 1 or S.shape != (3, f.size):
            raise ParameterError(f"spectrum table: f_hz of shape {f.shape} and S_u, S_v, S_w of shape {S.shape}; "
                                 "needs n frequencies and (3, n) values (columns f_hz, S_u, S_v, S_w)")
        if not np.isfinite(f).all() or (f < 0).any():
            j = int(np.argmax(~np.isfinite(f) | (f < 0)))
            raise ParameterError(f"spectrum table: f_hz[{j}] = {float(f[j])!r}; frequencies [Hz] must be finite and "
                                 ">= 0")
        if (np.diff(f) <= 0).any():
            j = int(np.argmax(np.diff(f) <= 0)) + 1
            raise ParameterError(f"spectrum table: f_hz[{j}] = {f[j]:g} Hz follows {f[j - 1]:g} Hz; frequencies "
                                 "must increase")
        _check_values("spectrum table", f, S)
        lines = line_frequencies(nt, dt_s)[1:]
        slack = COVER_SLACK / (nt * dt_s)
        if f[0] > lines[0] + slack or f[-1] < lines[-1] - slack:
            raise ParameterError(f"spectrum table: covers {f[0]:g} to {f[-1]:g} Hz; the run's lines need {lines[0]:g} "
                                 f"Hz (1/(nt dt)) to {lines[-1]:g} Hz (the highest line: 1/(2 dt) for an even nt)")
        if f.size == lines.size and np.array_equal(f, lines):
            return cls.from_values(nt, dt_s, S)
        return cls.from_values(nt, dt_s, [np.interp(lines, f, row) for row in S])
