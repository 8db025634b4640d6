"""The first-order variance budget of ln gamma-hat (``turbgen.validation.fit.evolution``) against realisations.

One realisation of a case of ``bench_fit_evo.py`` is fitted to get the coherence fit's gain a = d ln gamma / d r, the
one-point fit's gain G and the slope s = d ln gamma / d theta; then n realisations give the band estimates r
(co-coherence) and F (spectra) only (no fit: cheap). Printed: a^T C_rr a (the coherence's own variance), s^T G C_FF
G^T s (what the one-point fit adds) and a^T C_rF G^T s (their covariance), each from the model (the fit's weights,
``evo_cross``) and from the n realisations (bootstrap sd of the last).

    python benchmarks/bench_fit_evo_budget.py --case 0 --n 150
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import turbgen
from bench_fit_evo import CASES, GRID, POINTS
from turbgen.validation.fit import load_fit_data
from turbgen.validation.fit.evolution import CoherenceModel, _estimates, _Problem, fit_evolution, linear_terms, x_pairs
from turbgen.validation.fit.mann import fit_mann_data
from turbgen.validation.fit.spectra import estimate_bands


def bands_of(case: int, seed: int, nperseg: int) -> tuple:
    ae, L, G, evo, dx = CASES[case]
    fd = load_fit_data(turbgen.mann(L=L, gamma=G, ae=ae, evo=evo, planes=[0, dx], seed=seed, **GRID), None,
                       POINTS[case])
    return fd, _estimates(fd, nperseg, x_pairs(fd.u_xyz_m)), estimate_bands(fd, nperseg)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", type=int, default=0)
    ap.add_argument("--n", type=int, default=150)
    ap.add_argument("--seed0", type=int, default=5000)
    a_ = ap.parse_args()
    fd = bands_of(a_.case, 9999, 128)[0]
    fit = fit_mann_data(fd)
    e = fit_evolution(fd, fit.params, fit.nperseg, fit)
    pairs = x_pairs(fd.u_xyz_m)
    bands, r, factor = _estimates(fd, fit.nperseg, pairs)
    problem = _Problem(CoherenceModel(bands, fd, fit.params), tuple(pairs), r, factor)
    problem.set_weights(e.value_s)
    a, cross = linear_terms(problem, fd, fit, pairs, math.log(e.value_s))
    gs = fit.gain.T @ e.sensitivity
    R, F = [], []
    for seed in range(a_.seed0, a_.seed0 + a_.n):
        _, (_, r, _), b1 = bands_of(a_.case, seed, fit.nperseg)
        R.append(r.T.ravel())
        F.append(np.stack([b1.values[s] for s in fit.data], axis=1).ravel())
    R, F = np.array(R), np.array(F)
    n = len(R)

    def emp_cross(i):
        return a @ ((R[i] - R[i].mean(0)).T @ (F[i] - F[i].mean(0)) / (n - 1)) @ gs

    boot = np.random.default_rng(0).integers(0, n, (300, n))
    print(f"case {CASES[a_.case]}, n = {n}: model / realisations")
    print(f"a C_rr a    {a @ problem.chol @ problem.chol.T @ a:.5f} / {a @ np.cov(R.T) @ a:.5f}")
    print(f"s Sigma s   {e.sensitivity @ fit.cov_fit @ e.sensitivity:.5f} / {gs @ np.cov(F.T) @ gs:.5f} (G C_FF G^T)")
    print(f"a C_rF G s  {a @ cross @ gs:.5f} / {emp_cross(np.arange(n)):.5f} "
          f"+- {np.std([emp_cross(i) for i in boot]):.5f}")


if __name__ == "__main__":
    main()
