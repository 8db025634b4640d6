"""User yz coherence of the Kaimal-type generator: a site's coherence in place of the IEC exponential.

The generator samples, on every spectral line f_k = k / (nt dt) (k = 1 .. nt // 2), the yz coherence gamma(r, f_k)
[-] (un-squared, real, 1 at r = 0; Guo et al. 2023, Eq. 12 for the IEC one) at the separations r of the grid's
points. A user coherence is reduced to a table on the run's lines and nodes r_j, :class:`LineCoherence`, which the
run records in its store: a re-run, the validator and sweeps read the same numbers without the callable.

* a callable ``coh(f_hz, r_m, U_m_s)`` is evaluated on the lines x the grid's distinct separations;
* a table (``f_hz`` (m,), ``r_m`` (n,), ``coh`` (m, n)) is interpolated linearly in f onto the lines.

Between nodes the coherence is linear in r, beyond the last node held (only the circulant embedding's torus sees
those values; turbgen.synthesis.circulant checks its eigenvalues)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError
from turbgen.theory.lattice import line_frequencies

COLUMNS = ("f_hz", "r_m", "coh")
MAX_VALUES = 1 << 18  # most values a store records (lines x nodes): ~20 B of JSON each in its metadata


def grid_separations_m(ny: int, nz: int, dy_m: float, dz_m: float) -> np.ndarray:
    """The distinct distances [m] between points of an ny x nz grid, increasing from 0 (as the torus computes them)."""
    return np.unique(np.hypot(np.arange(ny)[:, None] * dy_m, np.arange(nz)[None, :] * dz_m))


def _locate(nodes: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(i, w): x as nodes[i] + w (nodes[i + 1] - nodes[i]), w in [0, 1] (held beyond the ends); w = 0 on a node."""
    if nodes.size == 1:
        return np.zeros(x.shape, int), np.zeros(x.shape)
    i = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    return i, np.clip((x - nodes[i]) / (nodes[i + 1] - nodes[i]), 0.0, 1.0)


@dataclass(frozen=True)
class LineCoherence:
    """The yz coherence ``coh`` (nt // 2, n) gamma(r_j, f_k) [-] in [-1, 1], 1 at r = 0, on a run's lines k = 1 ..
    nt // 2 (``nt`` samples ``dt_s`` [s] apart) and increasing nodes ``r_m`` (n,) [m] from 0."""

    nt: int
    dt_s: float
    r_m: tuple[float, ...]
    coh: tuple[tuple[float, ...], ...]

    def __post_init__(self):
        r, values = np.asarray(self.r_m, dtype=float), np.asarray(self.coh, dtype=float)
        lines = self.nt // 2
        if r.ndim != 1 or r.size < 1 or r[0] != 0 or (np.diff(r) <= 0).any() or not np.isfinite(r).all():
            raise ParameterError(f"coherence: r_m = {r.tolist()[:4]}...; needs increasing separations [m] from 0")
        if values.shape != (lines, r.size):
            raise ParameterError(f"coherence: {values.shape} values for {lines} lines x {r.size} separations")
        if values.size > MAX_VALUES:
            raise ParameterError(f"coherence: {lines} lines x {r.size} separations = {values.size} values; at most "
                                 f"{MAX_VALUES} are recorded with a field (lower `nt`, `ny`/`nz`, or give a table)")
        bad = ~np.isfinite(values) | (np.abs(values) > 1) | (np.arange(r.size) == 0) & (np.abs(values - 1) > 1e-12)
        if bad.any():
            k, j = np.argwhere(bad)[0]
            raise ParameterError(f"coherence: {float(values[k, j])!r} at f = {self.f_hz[k]:g} Hz, r = {r[j]:g} m; "
                                 "needs finite values in [-1, 1], 1 at r = 0")

    @property
    def f_hz(self) -> np.ndarray:
        """The lines f_k [Hz], k = 1 .. nt // 2."""
        return line_frequencies(self.nt, self.dt_s)[1:]

    def __call__(self, r_m, f_hz) -> np.ndarray:
        """gamma(r, f) [-] at broadcast separations r [m] and frequencies f [Hz], bilinear between the table's lines
        and nodes (held beyond them); exactly the table's value on a line and node."""
        r, f = np.broadcast_arrays(np.asarray(r_m, dtype=float), np.asarray(f_hz, dtype=float))
        table = np.asarray(self.coh, dtype=float)
        (k, wf), (j, wr) = _locate(self.f_hz, f), _locate(np.asarray(self.r_m), r)
        k1, j1 = np.minimum(k + 1, table.shape[0] - 1), np.minimum(j + 1, table.shape[1] - 1)
        near = (1 - wr) * table[k, j] + wr * table[k, j1]
        far = (1 - wr) * table[k1, j] + wr * table[k1, j1]
        return (1 - wf) * near + wf * far

    def to_table(self) -> dict:
        """The record of the store: ``f_hz`` [Hz], ``r_m`` [m] and ``coh`` [-] (lines x nodes) as lists (JSON)."""
        return {"f_hz": self.f_hz.tolist(), "r_m": list(self.r_m), "coh": [list(row) for row in self.coh]}

    @classmethod
    def from_values(cls, nt: int, dt_s: float, r_m, values) -> "LineCoherence":
        """The coherence of ``values`` (nt // 2, n) [-] at nodes ``r_m`` (n,) [m]."""
        rows = np.asarray(values, dtype=float).tolist()
        return cls(nt, float(dt_s), tuple(np.asarray(r_m, dtype=float).tolist()), tuple(tuple(row) for row in rows))

    @classmethod
    def from_callable(cls, coh: Callable, nt: int, dt_s: float, r_m, U_m_s: float) -> "LineCoherence":
        """``coh(f_hz (nl, 1), r_m (1, n), U_m_s)`` [-] on the lines x nodes ``r_m`` (the grid's separations);
        ParameterError if ``coh`` fails or does not return (nl, n) finite values in [-1, 1], 1 at r = 0."""
        f, r = line_frequencies(nt, dt_s)[1:, None], np.asarray(r_m, dtype=float)[None, :]
        try:
            values = np.broadcast_to(np.asarray(coh(f, r, U_m_s), dtype=float), (f.size, r.size))
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"coherence: the callable failed on {f.size} lines x {r.size} separations, or "
                                 f"did not return ({f.size}, {r.size}) values: {exc}") from None
        return cls.from_values(nt, dt_s, r_m, values)

    @classmethod
    def from_table(cls, f_hz, r_m, coh, nt: int, dt_s: float) -> "LineCoherence":
        """A table (f_hz (m,) increasing [Hz], r_m (n,), coh (m, n)) interpolated linearly in f onto the lines;
        ParameterError for a wrong shape, frequencies not increasing or not covering the lines, or bad values."""
        f, c = np.asarray(f_hz, dtype=float), np.asarray(coh, dtype=float)
        lines = line_frequencies(nt, dt_s)[1:]
        if f.ndim != 1 or c.ndim != 2 or c.shape[0] != f.size or (np.diff(f) <= 0).any():
            raise ParameterError(f"coherence table: f_hz of shape {f.shape}, coh of shape {c.shape}; needs m "
                                 "increasing frequencies [Hz] and (m, n) values at the n separations r_m")
        if f[0] > lines[0] or f[-1] < lines[-1]:
            raise ParameterError(f"coherence table: covers {f[0]:g} to {f[-1]:g} Hz; the run's lines need "
                                 f"{lines[0]:g} to {lines[-1]:g} Hz")
        if not (f.size == lines.size and np.array_equal(f, lines)):
            c = np.stack([np.interp(lines, f, column) for column in c.T], axis=1)
        return cls.from_values(nt, dt_s, r_m, c)
