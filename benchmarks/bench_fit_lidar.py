"""Coverage of the 95 % intervals of `turbgen fit mann LIDAR` (ae, L, and the eddy-evolution time from range gates).

For every realisation (seed) of a Mann space-time field with known (ae, L, Gamma, gamma) on the planes of a forward
pulsed beam's range gates (cases 2, 3: four beams 14 deg off the axis, 4 Hz), a virtual lidar (``turbgen.lidar``,
FWHM 30 m, 1 Hz) writes its dataset, and
``turbgen.fit_mann`` fits it with Gamma held at the truth (the grid model: the store's box). Coverage: the fraction
of realisations whose interval holds the truth; its binomial standard error is sqrt(p (1 - p) / n).

    python benchmarks/bench_fit_lidar.py --n 30 --case 0 --out benchmarks/fit_lidar_results.jsonl
    python benchmarks/bench_fit_lidar.py --summary benchmarks/fit_lidar_results.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

import turbgen

Z95 = 1.959963984540054

CASES = [  # (ae, L, Gamma, gamma [s], gate x [m]); cases 2, 3: the four inclined beams of FOUR (gamma from beam 0)
    (0.08, 30.0, 3.2, 200.0, (50.0, 100.0)),
    (0.05, 20.0, 3.9, 100.0, (50.0, 75.0, 100.0)),
    (0.08, 30.0, 3.2, 200.0, (50.0, 100.0)),
    (0.05, 20.0, 3.9, 100.0, (50.0, 75.0, 100.0)),
]
GRID = dict(nt=4096, ny=9, nz=9, dy=6.0, dz=6.0, U=10.0, dt=0.5)  # 2048 s; y = z = 0 is a grid point
WIDE = dict(GRID, ny=24, nz=24, dy=4.0, dz=4.0)  # the inclined beams' probe volumes reach |y|, |z| = 37 m
LIDAR = """kind = "pulsed"\nmount = "nacelle"\nranges_m = {gates}\nbeam_rate_hz = 1.0\nrotor_radius_m = 24.0
azimuth_deg = [0.0]\nelevation_deg = [0.0]\nfwhm_m = 30.0\n"""
FOUR = """kind = "pulsed"\nmount = "nacelle"\nranges_m = {gates}\nbeam_rate_hz = 4.0\nrotor_radius_m = 63.0
azimuth_deg = [14.4, 14.4, -14.4, -14.4]\nelevation_deg = [14.0, -14.0, -14.0, 14.0]\nfwhm_m = 30.0\n"""


def one(case: int, seed: int, work: Path) -> dict:
    """Generate, measure and fit one realisation; the estimates, intervals and CPU seconds of the fit."""
    ae, L, G, evo, gates = CASES[case]
    (work / "lidar.toml").write_text((FOUR if case >= 2 else LIDAR).format(gates=list(gates)))
    turbgen.mann(L=L, gamma=G, ae=ae, evo=evo, seed=seed, out=work / "f.zarr", overwrite=True,
                 planes=[0.0, *gates], **(WIDE if case >= 2 else GRID))
    turbgen.lidar(work / "f.zarr", work / "lidar.toml", out=work / "l.zarr",
                  overwrite=True)
    t0 = time.process_time()
    fit = turbgen.fit_mann(str(work / "l.zarr"), gamma=G)
    row = {"case": case, "seed": seed, "cpu_s": time.process_time() - t0, "chi2_dof": fit.chi2_dof,
           "flags": list(fit.flags)}
    for name, truth in (("ae", ae), ("length_scale_m", L)):
        v = getattr(fit, name)
        row[name] = {"truth": truth, "value": v.value, "ci95": list(v.ci95), "sd": v.sd_fit,
                     "wald": [v.value * math.exp(-Z95 * v.sd_fit), v.value * math.exp(Z95 * v.sd_fit)]}
    e = fit.evolution
    row["evo_time_s"] = None if e is None else {"truth": evo, "value": e.value_s, "ci95": list(e.ci95)}
    return row


def summary(path: str) -> None:
    """A markdown table per case: coverage +- binomial se, median estimate / truth, rms sd of the fit."""
    rows = [json.loads(line) for line in open(path)]
    print("| case (ae, L, Γ, γ, gates) | n | ae in CI | L in CI (Wald at L̂) | γ in CI | median ae/ae, L/L, γ/γ | sd ln L̂ "
          "(rms sd fit) | CPU s per fit (median) | flagged |")
    print("|---|---|---|---|---|---|---|---|---|")
    for case in sorted({r["case"] for r in rows}):
        rs = [r for r in rows if r["case"] == case]
        n = len(rs)

        def cover(name):
            if not any(r[name] for r in rs):
                return "—"
            hit = [r[name] is not None and r[name]["ci95"][0] <= r[name]["truth"] <= (r[name]["ci95"][1] or math.inf)
                   for r in rs]
            p = float(np.mean(hit))
            return f"{100 * p:.0f} % ± {100 * math.sqrt(p * (1 - p) / n):.0f}"

        wald = np.mean([r["length_scale_m"]["wald"][0] <= r["length_scale_m"]["truth"] <= r["length_scale_m"]["wald"][1]
                        for r in rs if "wald" in r["length_scale_m"]]) if "wald" in rs[0]["length_scale_m"] else math.nan
        ratio = [np.median([r[k]["value"] / r[k]["truth"] for r in rs if r[k]]) if any(r[k] for r in rs) else math.nan
                 for k in ("ae", "length_scale_m", "evo_time_s")]
        lnl = np.log([r["length_scale_m"]["value"] for r in rs])
        sd = math.sqrt(np.mean([r["length_scale_m"]["sd"] ** 2 for r in rs]))
        print(f"| {CASES[case]} | {n} | {cover('ae')} | {cover('length_scale_m')} ({100 * wald:.0f} %) | {cover('evo_time_s')} | "
              + ", ".join(f"{x:.3f}" for x in ratio) + f" | {np.std(lnl, ddof=1):.3f} ({sd:.3f}) | "
              f"{np.median([r['cpu_s'] for r in rs]):.1f} | {sum(bool(r['flags']) for r in rs)} |")
    print("\n| case | bias ln ae (± se) | sd ln ae (rms sd fit, ratio) | bias ln L (± se) | bias ln γ̂ (± se), sd | truth "
          "below / above: ae, L | Taylor excluded | median χ²/dof |\n|---|---|---|---|---|---|---|---|")
    for case in sorted({r["case"] for r in rows}):
        rs = [r for r in rows if r["case"] == case]

        def ln_err(name):
            return np.array([math.log(r[name]["value"] / r[name]["truth"]) for r in rs if r[name]])

        def side(name):
            below = sum(r[name]["truth"] < r[name]["ci95"][0] for r in rs)
            return f"{below} / {sum(r[name]['ci95'][1] is not None and r[name]['truth'] > r[name]['ci95'][1] for r in rs)}"

        e, sd = {n: ln_err(n) for n in ("ae", "length_scale_m", "evo_time_s")}, lambda x: np.std(x, ddof=1)
        fit_sd = math.sqrt(np.mean([r["ae"]["sd"] ** 2 for r in rs]))
        bias = {n: f"{x.mean():.3f} ± {sd(x) / math.sqrt(x.size):.3f}" for n, x in e.items() if x.size > 1}
        bias["evo_time_s"] = f"{bias['evo_time_s']}, {sd(e['evo_time_s']):.3f}" if "evo_time_s" in bias else "—"
        print(f"| {case} | {bias['ae']} | {sd(e['ae']):.3f} ({fit_sd:.3f}, {sd(e['ae']) / fit_sd:.2f}) | "
              f"{bias['length_scale_m']} | {bias['evo_time_s']} | {side('ae')}, "
              f"{side('length_scale_m')} | {sum(r['evo_time_s'] is not None and r['evo_time_s']['ci95'][1] is not None for r in rs)} / {len(rs)} | "
              f"{np.median([r['chi2_dof'] for r in rs]):.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", type=int, default=0)
    ap.add_argument("--n", type=int, default=30)
    ap.add_argument("--seed0", type=int, default=5000)
    ap.add_argument("--out", default="benchmarks/fit_lidar_results.jsonl")
    ap.add_argument("--summary", default=None)
    a = ap.parse_args()
    if a.summary:
        return summary(a.summary)
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(a.seed0, a.seed0 + a.n):
            row = one(a.case, seed, Path(tmp))
            with open(a.out, "a") as fh:
                fh.write(json.dumps(row) + "\n")
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
