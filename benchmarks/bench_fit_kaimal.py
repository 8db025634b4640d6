"""Parameter recovery of `turbgen fit kaimal`: coverage of the 95 % intervals on turbgen Kaimal fields.

For every realisation (seed) of an IEC Kaimal field (hub 90 m: L = 340.2, 113.4, 27.72 m, a = 12, Lc = 340.2 m;
nt 2048, dt 0.5 s, 4 x 4 points 12 m apart, one plane, v and w white as IEC) two fits:
  mast4     four sensors of u, v, w in one column (``points``: y = -6 m, z = -18, -6, 6, 18 m): all eight parameters;
  sonic1    one sensor (y = z = -6 m): the six spectral parameters (the coherence is not identified).
Coverage: the fraction of realisations whose 95 % interval holds the true value; with n realisations its binomial
standard error is sqrt(p (1 - p) / n). Also the median of (fitted / true - 1) and the ratio of the scatter of the
fitted ln value over the realisations to the mean analytic sd (1 when the intervals have the right width); for Lc
the number of intervals with an end not identified (the range's end inside) instead.

    python benchmarks/bench_fit_kaimal.py --n 60 --out /tmp/fit_kaimal.jsonl
    python benchmarks/bench_fit_kaimal.py --summary /tmp/fit_kaimal.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
from collections import defaultdict

import numpy as np

import turbgen
from turbgen.theory.kaimal import iec_kaimal_params

CASES = {"A, U = 10 m/s": dict(U=10.0, turb_class="A"), "B, U = 16 m/s": dict(U=16.0, turb_class="B")}
GRID = dict(nt=2048, dt=0.5, ny=4, nz=4, dy=12.0, dz=12.0, planes=[0], hub_height=90.0)
POINTS = {"mast4": [(-6.0, z) for z in (-18.0, -6.0, 6.0, 18.0)], "sonic1": [(-6.0, -6.0)]}


def truth(case: dict) -> dict:
    p = iec_kaimal_params(case["U"], case["turb_class"], GRID["hub_height"])
    return {**{f"sigma_{c}_m_s": s for c, s in zip("uvw", p.sigma_m_s)},
            **{f"length_{c}_m": v for c, v in zip("uvw", p.length_scales_m)}, "a_yz": p.a_yz, "lc_m": p.lc_m}


def run(n: int, seed0: int, out: str, cases: list) -> None:
    with open(out, "a") as fh:
        for name, case in ((c, CASES[c]) for c in cases):
            true = truth(case)
            for seed in range(seed0, seed0 + n):
                ds = turbgen.kaimal(seed=seed, **case, **GRID).load()
                for kind, pts in POINTS.items():
                    fit = turbgen.fit_kaimal(ds, points=pts)
                    rec = {n: None if n not in fit.values else
                           [fit.values[n].value, *fit.values[n].ci95, fit.values[n].sd_fit] for n in true}
                    fh.write(json.dumps({"case": name, "kind": kind, "seed": seed, "truth": true, "fit": rec,
                                         "flags": list(fit.flags)}) + "\n")
                    fh.flush()


def summary(path: str) -> None:
    rows = defaultdict(list)
    for line in open(path):
        r = json.loads(line)
        rows[(r["case"], r["kind"])].append(r)
    print("| case | data | parameter | n | coverage ± se | median bias | scatter / sd |")
    print("|---|---|---|---|---|---|---|")
    for (case, kind), rs in rows.items():
        for name, true in rs[0]["truth"].items():
            fits = np.array([r["fit"][name] for r in rs if r["fit"][name] is not None], float)  # None end: nan
            if fits.size == 0:
                print(f"| {case} | {kind} | {name} | {len(rs)} | not identified | | |")
                continue
            open_end = np.isnan(fits[:, 1:3]).any(axis=1)  # an end not identified: the interval reaches the range's
            cov = np.mean(~(fits[:, 1] > true) & ~(true > fits[:, 2]))
            se = math.sqrt(cov * (1 - cov) / len(fits)) if 0 < cov < 1 else math.sqrt(0.95 * 0.05 / len(fits))
            ratio = np.std(np.log(fits[:, 0]), ddof=1) / np.mean(fits[:, 3])
            print(f"| {case} | {kind} | {name} | {len(fits)} | {100 * cov:.0f} ± {100 * se:.0f} % | "
                  f"{100 * np.median(fits[:, 0] / true - 1):+.1f} % | "
                  f"{f'{open_end.sum()} open intervals' if open_end.any() else f'{ratio:.2f}'} |")
    flagged = sum(bool(r["flags"]) for rs in rows.values() for r in rs)
    print(f"\nflagged fits: {flagged} of {sum(map(len, rows.values()))}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=60, help="realisations per case")
    ap.add_argument("--seed0", type=int, default=1000)
    ap.add_argument("--out", default="/tmp/fit_kaimal.jsonl")
    ap.add_argument("--case", action="append", choices=list(CASES), help="run only these cases (default all)")
    ap.add_argument("--summary", help="print the table of a results file instead of running")
    a = ap.parse_args()
    summary(a.summary) if a.summary else run(a.n, a.seed0, a.out, a.case or list(CASES))
