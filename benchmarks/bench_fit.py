"""Parameter recovery of `turbgen fit mann`: coverage of the 95 % intervals on turbgen fields with known parameters.

For every realisation (seed) of a Mann field with known (ae, L, Gamma) (frozen, one plane, in memory) three fits,
each against the grid's expectation (the lattice sum over the generator's box, what its points hold):
  grid      the field itself (its sub-lattice of 8 x 8 points);
  mast4     four sensors of u, v, w in the hub column (``points``: z = -33, -9, 9, 33 m at y = 3 m);
  sonic1    one sensor of u, v, w next to the hub (y = z = 3 m);
and, against the continuous model, a sensor's record (``bench_fit_wetb.sonic_series``: --nt samples at --dt):
  sonic     one sensor's u, v, w series of the continuous model at the record's lines (kind "sonic<nt>").
Coverage: the fraction of realisations whose 95 % interval holds the true value, per parameter; with n
realisations its binomial standard error is sqrt(0.95 0.05 / n).

    python benchmarks/bench_fit.py --n 50 --out benchmarks/fit_results.jsonl [--kinds grid --seed0 1007 --cache DIR]
    python benchmarks/bench_fit.py --kinds sonic --nt 12000 --dt 0.05 --cases 0 --seed0 5000 --out /tmp/sonic.jsonl
    python benchmarks/fit_summary.py benchmarks/fit_results.jsonl
"""

from __future__ import annotations

import argparse
import json
import pickle
import time
from pathlib import Path

import numpy as np
from bench_fit_wetb import U_M_S, sonic_series

import turbgen
from turbgen.spec.constraints import PointSensor, PointSeries

CASES = [  # (ae, L, Gamma) of the fields
    (0.08, 30.0, 3.2),
    (0.05, 60.0, 2.0),
]
GRID = dict(nt=2048, ny=16, nz=16, dy=6.0, dz=6.0, planes=[0], evo=None, U=12.0)
POINTS = {"grid": None, "mast4": [(3.0, z) for z in (-33.0, -9.0, 9.0, 33.0)], "sonic1": [(3.0, 3.0)]}


def field(case, seed: int, cache: str | None):
    """The Mann field of ``case`` and ``seed``, from (or into) the directory ``cache`` when given."""
    ae, L, G = case
    path = Path(cache) / f"{ae}_{L}_{G}_{seed}.pkl" if cache else None
    if path is not None and path.exists():
        with open(path, "rb") as fh:
            return pickle.load(fh)
    ds = turbgen.mann(L=L, gamma=G, ae=ae, seed=seed, **GRID).load()
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as fh:
            pickle.dump(ds, fh)
    return ds


def sonic(case, seed: int, nt: int, dt_s: float) -> PointSeries:
    """One sensor's fluctuation series of ``case`` (``bench_fit_wetb.sonic_series``)."""
    sensor = PointSensor("s", 0.0, 0.0, 0.0, None, sonic_series(case, seed, nt, dt_s))
    return PointSeries("sonic", dt_s * np.arange(nt), (sensor,), total_wind=False, noise_m_s=None, source="sonic")


def covered(fit, truth) -> dict:
    out = {}
    for name, value in zip(("ae", "length_scale_m", "gamma"), truth):
        v = getattr(fit, name)
        out[name] = None if v.held else bool(v.ci95[0] <= value <= v.ci95[1])
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=50, help="realisations per case")
    ap.add_argument("--seed0", type=int, default=1000)
    ap.add_argument("--out", default="benchmarks/fit_results.jsonl")
    ap.add_argument("--kinds", default="grid,mast4,sonic1", help="fits to run, of grid, mast4, sonic1, sonic")
    ap.add_argument("--nt", type=int, default=12000, help="samples of a sonic record")
    ap.add_argument("--dt", type=float, default=0.05, help="sampling interval of a sonic record [s]")
    ap.add_argument("--cases", default=None, help="indices into CASES to run (default all), e.g. 0")
    ap.add_argument("--cache", default=None, help="directory of the fields (pickled Datasets), reused when there")
    a = ap.parse_args()
    with open(a.out, "a") as fh:
        for seed in range(a.seed0, a.seed0 + a.n):  # cases interleaved: a stopped run covers both
            for case in [CASES[int(k)] for k in a.cases.split(",")] if a.cases else CASES:
                ds = None if a.kinds == "sonic" else field(case, seed, a.cache)
                for kind in a.kinds.split(","):
                    t0 = time.perf_counter()
                    if kind == "sonic":
                        fit, kind = turbgen.fit_mann(sonic(case, seed, a.nt, a.dt), U=U_M_S), f"sonic{a.nt}"
                    else:
                        fit = turbgen.fit_mann(ds, points=POINTS[kind])
                    row = {"case": case, "seed": seed, "kind": kind, "seconds": time.perf_counter() - t0,
                           "covered": covered(fit, case), "fit": fit.to_dict()}
                    fh.write(json.dumps(row) + "\n")
                    fh.flush()


if __name__ == "__main__":
    main()
