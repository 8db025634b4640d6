"""A sonic's path in `turbgen fit mann`: coverage of the 95 % intervals on path-averaged sensor records.

Every realisation (seed): one sensor's u, v, w, 10 minutes at 20 Hz, U = 8 m/s, Gaussian with the continuous Mann
spectra (ae, L, Gamma) = (0.08, 30 m, 3.2) times the transfer of a p = 0.15 m path computed from the Mann tensor
itself (its quadrature with the sinc weights: tests/validate/test_fit_sonic_path.mann_transfer, not the fit's
isotropic table); fitted with ``path_m`` ("path") and as a point ("point"); and the same draw without the path's
filter fitted as a point ("bare": what the path fit should reproduce). Coverage: the fraction of realisations whose
95 % interval holds the truth (binomial se sqrt(p (1 - p) / n)); z: (fitted - true) / fitted sd, in ln for ae and
L; "ok": the fits without a flag.

    python benchmarks/bench_fit_sonic_path.py --n 50 --out /tmp/sonic_path.jsonl
    python benchmarks/bench_fit_sonic_path.py --summary /tmp/sonic_path.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

import turbgen
from turbgen.spec.constraints import PointSensor, PointSeries
from turbgen.theory.mann_spectra import one_point_spectra
from turbgen.theory.params import MannParams

sys.path.insert(0, str(Path(__file__).parents[1] / "tests" / "validate"))  # the tests' reference transfer and draw
from test_fit_mann import sonic_series  # noqa: E402
from test_fit_sonic_path import mann_transfer  # noqa: E402

TRUTH = {"ae": 0.08, "length_scale_m": 30.0, "gamma": 3.2}
N, DT_S, U_M_S, PATH_M = 12000, 0.05, 8.0, 0.15


def run(n: int, seed0: int, out: str) -> None:
    dk = 2 * np.pi / (N * DT_S * U_M_S)
    k1 = dk * np.arange(1, N // 2)
    params = MannParams(*TRUTH.values())
    nodes = np.geomspace(0.01 / PATH_M, k1[-1] * 1.01, 40)
    bare = one_point_spectra(k1, params)
    F = {name: bare[name] * np.interp(np.log(k1), np.log(nodes), t, left=1.0)
         for name, t in zip(("F11", "F22", "F33", "F13"), mann_transfer(nodes, params, PATH_M).values())}
    with open(out, "a") as fh:
        for seed in range(seed0, seed0 + n):
            for kind, spectra, path in (("path", F, PATH_M), ("point", F, None), ("bare", bare, None)):
                sensor = PointSensor("s", 0.0, 0.0, 0.0, None, sonic_series(spectra, dk, N, seed), path)
                fit = turbgen.fit_mann(PointSeries("s", DT_S * np.arange(N), (sensor,), False, None, "sonic"), U=U_M_S)
                fh.write(json.dumps({"seed": seed, "kind": kind, "ok": fit.ok, "flags": fit.flags, **{
                    p: [getattr(fit, p).value, *getattr(fit, p).ci95, getattr(fit, p).sd_fit] for p in TRUTH}}) + "\n")
                fh.flush()


def summary(path: str) -> None:
    rows = defaultdict(list)
    for line in open(path):
        r = json.loads(line)
        rows[r["kind"]].append(r)
    print("| fit | n | ok | " + " | ".join(f"{p} coverage | {p} mean z" for p in TRUTH) + " |")
    for kind, rs in rows.items():
        cells = []
        for p, t in TRUTH.items():
            cover = np.mean([r[p][1] <= t <= r[p][2] for r in rs])
            x = (lambda v: v) if p == "gamma" else math.log
            z = np.mean([(x(r[p][0]) - x(t)) / r[p][3] for r in rs])
            cells.append(f"{100 * cover:.0f} % ± {100 * math.sqrt(cover * (1 - cover) / len(rs)):.0f} | {z:+.2f}")
        print(f"| {kind} | {len(rs)} | {sum(r['ok'] for r in rs)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=50)
    ap.add_argument("--seed0", type=int, default=6000)
    ap.add_argument("--out", default="/tmp/sonic_path.jsonl")
    ap.add_argument("--summary")
    a = ap.parse_args()
    summary(a.summary) if a.summary else run(a.n, a.seed0, a.out)
