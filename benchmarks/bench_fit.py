"""Parameter recovery of `turbgen fit mann`: coverage of the 95 % intervals on turbgen fields with known parameters.

For every realisation (seed) of a Mann field with known (ae, L, Gamma) (frozen, one plane, in memory) three fits:
  grid      the field itself (its sub-lattice of 8 x 8 points), against the lattice sum over the generator's box;
  mast4     four sensors of u, v, w at the hub column (z = -18, -6, 6, 18 m ... the grid points nearest), against
            the continuous model (what a met mast gives);
  sonic1    one sensor of u, v, w at the hub, continuous model.
Coverage: the fraction of realisations whose 95 % interval holds the true value, per parameter; with n
realisations its binomial standard error is sqrt(0.95 0.05 / n). The sensor fits use the continuous model on a
turbgen field, whose point spectra lack the wavenumbers beyond the grid's Nyquist and below its box: the bias this
gives is what the grid model removes, and it shows in their coverage.

    python benchmarks/bench_fit.py --n 50 --out benchmarks/fit_results.jsonl [--kinds grid --seed0 1007]
    python benchmarks/fit_summary.py benchmarks/fit_results.jsonl
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import turbgen
from turbgen.spec.constraints import PointSensor, PointSeries

CASES = [  # (ae, L, Gamma) of the fields
    (0.08, 30.0, 3.2),
    (0.05, 60.0, 2.0),
]
GRID = dict(nt=2048, ny=16, nz=16, dy=6.0, dz=6.0, planes=[0], evo=None, U=12.0)


def sensors(ds, n: int) -> PointSeries:
    """n sensors of u, v, w at the hub column (y = 0 nearest), spread over z."""
    iy = int(np.argmin(np.abs(ds.y.values)))
    iz = np.linspace(2, ds.sizes["z"] - 3, n).round().astype(int) if n > 1 else [int(np.argmin(np.abs(ds.z.values)))]
    out = [PointSensor(f"s{k}", 0.0, float(ds.y[iy]), float(ds.z[k_z]), None,
                       {c: ds[c].values[:, 0, iy, k_z].astype(float) for c in "uvw"}) for k, k_z in enumerate(iz)]
    return PointSeries(f"mast{n}", ds.t.values, tuple(out), False, None, f"mast{n}")


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
    ap.add_argument("--kinds", default="grid,mast4,sonic1", help="fits to run, of grid, mast4, sonic1")
    a = ap.parse_args()
    with open(a.out, "a") as fh:
        for seed in range(a.seed0, a.seed0 + a.n):  # cases interleaved: a stopped run covers both
            for case in CASES:
                ae, L, G = case
                ds = turbgen.mann(L=L, gamma=G, ae=ae, seed=seed, **GRID)
                fits = {"grid": (ds, {}), "mast4": (sensors(ds, 4), {"U": GRID["U"]}),
                        "sonic1": (sensors(ds, 1), {"U": GRID["U"]})}
                for kind in a.kinds.split(","):
                    data, kw = fits[kind]
                    t0 = time.perf_counter()
                    fit = turbgen.fit_mann(data, **kw)
                    row = {"case": case, "seed": seed, "kind": kind, "seconds": time.perf_counter() - t0,
                           "covered": covered(fit, case), "fit": fit.to_dict()}
                    fh.write(json.dumps(row) + "\n")
                    fh.flush()


if __name__ == "__main__":
    main()
