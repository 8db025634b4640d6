"""Sweep throughput (fields per minute) and scaling from 1 to 2 LocalCluster workers.

    python benchmarks/bench_sweep.py [--model mann|kaimal] [--seeds 1-8] [--nt 1024] [--n 32] [--workers 1,2]

Each worker count runs the same sweep (one preset, one speed, the given seeds, so the Mann stencil
is built once and reused) into a fresh directory on a LocalCluster of that many single-threaded
worker processes, each run using cores/workers threads (as `turbgen sweep` does). The
cluster start-up is timed separately from the sweep (stencil + runs + checksums + manifest). The
stores of the different worker counts are checked to be identical (checksums). Results are printed
and written to benchmarks/results/bench_sweep.json.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import shutil
import tempfile
import time
from pathlib import Path

from distributed import Client, LocalCluster

from turbgen.sweep import make_plan, run_sweep


def _seeds(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="mann", choices=["mann", "kaimal"])
    ap.add_argument("--preset", default="neutral")
    ap.add_argument("--seeds", default="1-8", help="seed range, e.g. 1-8")
    ap.add_argument("--nt", type=int, default=1024, help="time steps per field")
    ap.add_argument("--n", type=int, default=32, help="ny = nz")
    ap.add_argument("--dy", type=float, default=5.0, help="dy = dz [m]")
    ap.add_argument("--workers", default="1,2", help="worker counts to compare")
    ap.add_argument("--out", default="benchmarks/results/bench_sweep.json")
    args = ap.parse_args()
    grid = {"nt": args.nt, "dt": 0.5, "ny": args.n, "nz": args.n, "dy": args.dy}
    seeds = _seeds(args.seeds)
    rows = []
    checksums = {}
    for workers in [int(w) for w in args.workers.split(",")]:
        d = Path(tempfile.mkdtemp(prefix="bench_sweep_"))
        try:
            plan = make_plan(out=d, models=[args.model], presets=[args.preset], speeds=[16.0], seeds=seeds,
                             grid=grid)  # fmt: skip
            t0 = time.perf_counter()
            with LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None,
                              silence_logs=logging.ERROR) as cluster, Client(cluster) as client:  # fmt: skip
                startup = time.perf_counter() - t0
                t0 = time.perf_counter()
                result = run_sweep(plan, client=client, progress=False, threads=max(1, os.cpu_count() // workers))
                seconds = time.perf_counter() - t0
            assert result.ok, [r["error"] for r in result.records if r["error"]]
            checksums[workers] = [r["checksum"] for r in result.records]
            per_field = [r["duration_s"] for r in result.records]
        finally:
            shutil.rmtree(d, ignore_errors=True)
        rows.append({
            "workers": workers, "fields": len(seeds), "cluster_startup_s": round(startup, 2),
            "seconds": round(seconds, 2),
            "fields_per_minute": round(60 * len(seeds) / seconds, 2),
            "mean_task_seconds": round(sum(per_field) / len(per_field), 2),
        })  # fmt: skip
        print(f"{args.model} {args.preset}, {len(seeds)} fields of {args.nt} x 11 x {args.n} x {args.n}, "
              f"{workers} worker(s): {seconds:.1f} s (+{startup:.1f} s cluster start), "
              f"{rows[-1]['fields_per_minute']:.1f} fields/min")  # fmt: skip
    same = len({tuple(c) for c in checksums.values()}) == 1
    base = rows[0]["seconds"]
    for r in rows:
        r["speedup_vs_first"] = round(base / r["seconds"], 2)
    print(f"speed-up {rows[0]['workers']} -> {rows[-1]['workers']} workers: {rows[-1]['speedup_vs_first']:.2f}x; "
          f"identical fields for every worker count: {same}  (cores: {os.cpu_count()})")  # fmt: skip
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"args": vars(args), "rows": rows, "identical": same}, indent=1) + "\n")


if __name__ == "__main__":
    main()
