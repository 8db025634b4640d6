"""The Mann one-point spectra tabulated in (k1 L, Gamma): what makes a fit take seconds.

F_ij(k1; ae, L, Gamma) = ae L^(5/3) f_ij(k1 L, Gamma) exactly (the Mann (1994) tensor, Eq. 13-17, depends on k L
only; Guo et al. 2023, Eq. 8). f_ij is tabulated on X_NODES x GAMMA_NODES and interpolated: cubic spline in log k1 L
of log f_ii and of rho_13 = f_13 / sqrt(f_11 f_33), Lagrange cubic in Gamma, inertial slopes beyond the largest k1 L.
One table per eddy lifetime, built by ``python -m turbgen.validation.fit.table`` into TABLE_PATHS (shipped)."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline, PPoly

from turbgen.errors import ParameterError
from turbgen.theory import ranges
from turbgen.theory.mann_spectra import one_point_spectra
from turbgen.theory.params import LIFETIMES, MannParams

NAMES = {"uu": "F11", "vv": "F22", "ww": "F33", "uw": "F13"}
X_NODES = np.geomspace(1e-5, 1e5, 81)  # k1 L nodes
GAMMA_STEP = 0.25
GAMMA_NODES = np.arange(0.0, ranges.RANGES["gamma"].hi + GAMMA_STEP / 2, GAMMA_STEP)
TABLE_PATHS = {lt: Path(__file__).with_name(f"mann_table{'' if lt == 'guo' else f'_{lt}_lifetime'}.npz") for lt in LIFETIMES}


def table_column(gamma: float, lifetime: str = "guo") -> np.ndarray:
    """(4, len(X_NODES)) log f_11, log f_22, log f_33 and rho_13 = f_13 / sqrt(f_11 f_33) at Gamma = ``gamma``
    (ae = 1, L = 1 m; rho_13 is tabulated rather than log |f_13|: f_13 = 0 at Gamma = 0)."""
    f = one_point_spectra(X_NODES, MannParams(1.0, 1.0, float(gamma), lifetime))
    rho = f["F13"] / np.sqrt(f["F11"] * f["F33"]) if gamma > 0 else np.zeros(X_NODES.size)
    return np.stack([np.log(f["F11"]), np.log(f["F22"]), np.log(f["F33"]), rho])


def build_table(lifetime: str = "guo", path=None) -> None:
    """Write the table of ``lifetime`` (every Gamma node) to ``path`` (a .npz file; default its TABLE_PATHS one)."""
    cols = np.stack([table_column(g, lifetime) for g in GAMMA_NODES])
    np.savez_compressed(path or TABLE_PATHS[lifetime], log_f=cols, x_nodes=X_NODES, gamma_nodes=GAMMA_NODES)


def load_table(lifetime: str = "guo") -> np.ndarray:
    """(len(GAMMA_NODES), 4, len(X_NODES)) columns (``table_column``) of ``lifetime`` from TABLE_PATHS, checked
    against the nodes of this module."""
    path = TABLE_PATHS[lifetime]
    with np.load(path) as t:
        if not (np.array_equal(t["x_nodes"], X_NODES) and np.array_equal(t["gamma_nodes"], GAMMA_NODES)):
            raise ParameterError(f"{path} was built for other nodes: rebuild it (python -m "
                                 "turbgen.validation.fit.table)")
        return t["log_f"]


@lru_cache(maxsize=2)
def table_spline(lifetime: str = "guo") -> CubicSpline:
    """Cubic splines in log k1 L of all columns of ``load_table(lifetime)``, built once (linear in the data)."""
    return CubicSpline(np.log(X_NODES), load_table(lifetime), axis=2)


def scaled_spectra(x: np.ndarray, gamma: float, lifetime: str = "guo") -> dict:
    """f_ij(k1 L, Gamma) (module docstring), two-sided [m^3 s^-2 per ae L^(5/3)], at ``x`` = k1 L > 0 for Gamma
    ``gamma`` and the table of ``lifetime`` ("guo" or "mann"): {"uu", "vv", "ww", "uw" -> f(x)}; F13 < 0."""
    g = ranges.check("gamma", gamma, "Gamma (fitted, -)")
    i0 = int(np.clip(np.floor(g / GAMMA_STEP) - 1, 0, GAMMA_NODES.size - 4))  # the 4 Lagrange nodes about Gamma
    nodes, t = np.arange(i0, i0 + 4), g / GAMMA_STEP
    weights = np.array([np.prod([(t - nodes[m]) / (nodes[k] - nodes[m]) for m in range(4) if m != k])
                        for k in range(4)])
    s, lx, top = table_spline(lifetime), np.log(x), np.log(X_NODES[-1])
    spline = PPoly.construct_fast(np.tensordot(s.c[:, :, nodes], weights, axes=([2], [0])), s.x)(
        np.clip(lx, s.x[0], top)).T  # (4, x.size)
    out = {n: np.exp(spline[k] - 5.0 / 3.0 * np.maximum(lx - top, 0.0)) for k, n in enumerate(("uu", "vv", "ww"))}
    rho = spline[3] * np.exp(-2.0 / 3.0 * np.maximum(lx - top, 0.0))  # F13 ~ k1^(-7/3) in the inertial range
    out["uw"] = rho * np.sqrt(out["uu"] * out["ww"])
    return out


if __name__ == "__main__":
    for name in TABLE_PATHS:
        build_table(name)
