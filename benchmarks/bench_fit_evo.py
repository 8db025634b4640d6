"""Coverage of the 95 % interval of the eddy-evolution time gamma fitted by `turbgen fit mann` to two planes along x.

For every realisation (seed) of a Mann space-time field with known (ae, L, Gamma, gamma) on two planes dx apart (in
memory, the grid model) the fit (``turbgen.fit_mann``: ae, L, Gamma from the one-point spectra, then gamma from the
co-coherence of u between the planes' 8 x 8 sub-lattices) and, to tell the interval's own calibration from the
uncertainty that L and Gamma carry into it, gamma alone with ae, L, Gamma held at their true values ("oracle").
Coverage: the fraction of realisations whose interval holds the true gamma; its binomial standard error is
sqrt(p (1 - p) / n).

    python benchmarks/bench_fit_evo.py --n 50 --out benchmarks/fit_evo_results.jsonl [--case 0 --seed0 2000]
    python benchmarks/bench_fit_evo.py --summary benchmarks/fit_evo_results.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

import turbgen
from turbgen.theory.params import MannParams
from turbgen.validation.fit import load_fit_data
from turbgen.validation.fit.evolution import fit_evolution

CASES = [  # (ae, L, Gamma, gamma [s], dx [m])
    (0.08, 30.0, 3.2, 100.0, 100.0),
    (0.08, 30.0, 3.2, 400.0, 60.0),
]
GRID = dict(nt=1024, ny=12, nz=12, dy=6.0, dz=6.0, U=10.0, dt=0.5)


def one(case: int, seed: int) -> dict:
    ae, L, G, evo, dx = CASES[case]
    t0 = time.perf_counter()
    ds = turbgen.mann(L=L, gamma=G, ae=ae, evo=evo, planes=[0, dx], seed=seed, **GRID)
    t1 = time.perf_counter()
    fit = turbgen.fit_mann(ds)
    t2 = time.perf_counter()
    oracle = fit_evolution(load_fit_data(ds), MannParams(ae, L, G), {}, fit.nperseg)
    e = fit.evolution
    out = {"case": case, "seed": seed, "truth": evo, "dx_m": dx, "value": e.value_s, "ci95": list(e.ci95),
           "oracle_value": oracle.value_s, "oracle_ci95": list(oracle.ci95), "L": fit.length_scale_m.value,
           "chi2": e.chi2, "dof": e.dof, "chi2_frozen": e.chi2_frozen, "t_gen_s": t1 - t0, "t_fit_s": t2 - t1}
    return out


def inside(ci, truth) -> bool:
    return ci[0] <= truth and (ci[1] is None or truth <= ci[1])


def summary(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    print("| case (ae, L, Γ, γ, dx) | n | coverage fit (± se) | coverage oracle (± se) | median γ̂ / γ | "
          "mean χ²/dof |")
    print("|---|---|---|---|---|---|")
    for c, spec in enumerate(CASES):
        rs = [r for r in rows if r["case"] == c]
        if not rs:
            continue
        n = len(rs)
        cells = []
        for key in ("ci95", "oracle_ci95"):
            p = np.mean([inside(r[key], r["truth"]) for r in rs])
            cells.append(f"{100 * p:.1f} % ± {100 * math.sqrt(p * (1 - p) / n):.1f}")
        ratio = np.median([r["value"] / r["truth"] for r in rs])
        chi = np.mean([r["chi2"] / r["dof"] for r in rs])
        print(f"| {spec} | {n} | {cells[0]} | {cells[1]} | {ratio:.3f} | {chi:.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=50, help="realisations")
    ap.add_argument("--case", type=int, default=0)
    ap.add_argument("--seed0", type=int, default=2000)
    ap.add_argument("--out", default="benchmarks/fit_evo_results.jsonl")
    ap.add_argument("--summary", default=None, help="print the coverage table of this results file and stop")
    a = ap.parse_args()
    if a.summary:
        summary(a.summary)
        return
    with open(a.out, "a") as fh:
        for seed in range(a.seed0, a.seed0 + a.n):
            fh.write(json.dumps(one(a.case, seed)) + "\n")
            fh.flush()


if __name__ == "__main__":
    main()
