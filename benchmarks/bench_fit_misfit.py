"""The misfit note's false-alarm rate: chi2/dof of fits of turbgen fields against their own model.

A fit notes "the model misfits" when chi2/dof over its dof has a chi^2 tail probability below MISFIT_P (1e-3); a
right model's whitened residuals are chi^2_dof, so about 1 in 1000 fits (per spectrum for Kaimal) notes it by chance.

    python benchmarks/bench_fit_misfit.py --kaimal 150 --seed0 6000 --out benchmarks/fit_kaimal_chi2.jsonl
    python benchmarks/bench_fit_misfit.py --summary benchmarks/fit_kaimal_chi2.jsonl
    python benchmarks/bench_fit_misfit.py --summary benchmarks/fit_lidar_results_bd120d0.jsonl --dof 9

Kaimal: the fields and points of bench_fit_kaimal.py (two IEC cases, a 4-sensor mast and one sensor), each spectrum's
chi2/dof and band count per row. Lidar rows (bench_fit_lidar.py) hold one chi2/dof; their dof (11 bands - 2 for
both of its cases) is given with --dof.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict

import numpy as np
from scipy.stats import chi2

import turbgen
from bench_fit_kaimal import CASES, GRID, POINTS
from turbgen.validation.fit.result import MISFIT_P


def run(n: int, seed0: int, out: str) -> None:
    with open(out, "a") as fh:
        for name, case in CASES.items():
            for seed in range(seed0, seed0 + n):
                ds = turbgen.kaimal(seed=seed, **case, **GRID).load()
                for kind, pts in POINTS.items():
                    fit = turbgen.fit_kaimal(ds, points=pts)
                    fh.write(json.dumps({"case": name, "kind": kind, "seed": seed, "chi2": fit.chi2_dof,
                                         "n": {s: int(fit.f_hz.size) for s in fit.fitted},
                                         "flags": list(fit.flags)}) + "\n")


def summary(path: str, dof: int | None) -> None:
    rows, found = [json.loads(line) for line in open(path)], defaultdict(list)
    for r in rows:
        if "chi2" in r:  # Kaimal: per spectrum (the coherence's chi2 is not chi^2_dof: not noted)
            for s, v in r["chi2"].items():
                if s != "coherence":
                    found[r["kind"]].append((v, r["n"][s] - 2))
        else:
            found[f"lidar case {r['case']}"].append((r["chi2_dof"], dof))
    print(f"| data | spectra | mean chi2/dof | sd (chi2_dof/dof: sqrt(2/dof)) | p < 0.05 | p < {MISFIT_P:g} |")
    print("|---|---|---|---|---|---|")
    for kind, vals in found.items():
        v, d = np.array(vals).T
        p = chi2.sf(v * d, d)
        print(f"| {kind} | {len(v)} | {v.mean():.3f} | {v.std():.3f} ({np.sqrt(2 / d.mean()):.3f}) | "
              f"{(p < 0.05).sum()} | {(p < MISFIT_P).sum()} |")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--kaimal", type=int, help="realisations per Kaimal case")
    ap.add_argument("--seed0", type=int, default=6000)
    ap.add_argument("--out")
    ap.add_argument("--summary")
    ap.add_argument("--dof", type=int, help="dof of lidar rows")
    a = ap.parse_args()
    if a.summary:
        summary(a.summary, a.dof)
    else:
        run(a.kaimal, a.seed0, a.out)
