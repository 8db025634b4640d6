"""Benchmark: `turbgen kaimal` vs the evoTurb pipeline (one independent 3-D field per plane) with pyconturb.

    python benchmarks/bench_kaimal.py              # default case + pyconturb (1 plane, reduced nt) + 64 x 64
    python benchmarks/bench_kaimal.py --pyconturb-nt 512 --skip-64
    python benchmarks/bench_kaimal.py --repeat 5     # the default case 5 times, each in a new process

The default case runs ``--repeat`` times (default 3), each in a new process (imports, caches and memory as a first
run pays them), and the fastest is compared (this VM's timings vary by +-15 % within minutes); all are printed.

Default case: U = 16 m/s, IEC class A, hub 90 m, 4096 x 11 x 31 x 31 at dt = 0.5 s, 5 m spacing.
turbgen writes the whole 4-D field (3 components, all planes) to a zarr store.

pyconturb (the Veers method with a Cholesky factor per frequency, IEC coherence on u, v and w white,
as evoTurb gets from TurbSim) is timed for ONE plane on the same 31 x 31 grid and dt, but with
reduced numbers of time steps (default 64 and 256, i.e. 32 and 128 of the 2048 frequencies): its
cost is a fixed part plus a part per frequency, so the two timings give both, and the full time is
EXTRAPOLATED as (fixed + per_frequency x 2048) x 11 planes. The extrapolation is printed as such;
evoTurb's own mixing step is not counted (it favours pyconturb).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# as the `turbgen` command does before numpy loads OpenBLAS (turbgen.cli.main): its threads only oversubscribe
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from turbgen.grid import Grid  # noqa: E402
from turbgen.spec.defaults import DEFAULT_PLANES_M  # noqa: E402
from turbgen.runs.kaimal import run_kaimal  # noqa: E402
from turbgen.spec.kaimal import KaimalRun, kaimal_params  # noqa: E402

U, HUB, CLASS = 16.0, 90.0, "A"


def time_turbgen(ny: int, dy: float, workdir: Path, nt: int = 4096) -> dict:
    grid = Grid(nt, 0.5, tuple(DEFAULT_PLANES_M), ny, ny, dy, dy)
    run = KaimalRun(kaimal_params(U, CLASS, HUB), grid, U, seed=1, hub_height_m=HUB, turb_class=CLASS)
    out = workdir / f"kaimal_{ny}x{ny}.zarr"
    t0 = time.perf_counter()
    s = run_kaimal(run, out, overwrite=True)
    s["wall_s"] = time.perf_counter() - t0
    shutil.rmtree(out, ignore_errors=True)
    return s


def time_pyconturb_plane(nt_reduced: int, ny: int = 31, dy: float = 5.0) -> tuple[float, int]:
    """Seconds for one 3-D pyconturb field (u, v, w) on the ny x ny grid with nt_reduced steps at dt 0.5 s."""
    from pyconturb import gen_spat_grid, gen_turb

    y = (np.arange(ny) - (ny - 1) / 2) * dy
    z = HUB + (np.arange(ny) - (ny - 1) / 2) * dy
    spat = gen_spat_grid(y, z)
    t0 = time.perf_counter()
    gen_turb(spat, T=nt_reduced * 0.5, nt=nt_reduced, u_ref=U, z_ref=HUB, turb_class=CLASS.lower(), seed=1,
             coh_model="iec", dtype=np.float64)
    return time.perf_counter() - t0, nt_reduced // 2


def time_default_in_new_processes(repeat: int) -> tuple[dict, list[float]]:
    """The default case ``repeat`` times, each in a new process: (the fastest run's summary, all wall times [s])."""
    runs = []
    for _ in range(repeat):
        proc = subprocess.run([sys.executable, __file__, "--child-default"], capture_output=True, text=True, check=True)
        runs.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    return min(runs, key=lambda r: r["wall_s"]), [r["wall_s"] for r in runs]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3, help="runs of the default case, each in a new process")
    ap.add_argument("--child-default", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--pyconturb-nt", default="64,256", help="two reduced step counts of the timed pyconturb plane")
    ap.add_argument("--skip-pyconturb", action="store_true")
    ap.add_argument("--skip-64", action="store_true")
    args = ap.parse_args()
    if args.child_default:  # one run of the default case for time_default_in_new_processes
        with tempfile.TemporaryDirectory(dir=".") as tmp:
            s = time_turbgen(31, 5.0, Path(tmp))
        print(json.dumps({k: s[k] for k in ("wall_s", "max_torus", "yz_clip_error")}))
        return
    print(f"machine: {os.cpu_count()} cores; U {U:g} m/s, class {CLASS}, hub {HUB:g} m, dt 0.5 s, "
          f"{len(DEFAULT_PLANES_M)} planes")
    with tempfile.TemporaryDirectory(dir=".") as tmp:
        tmp = Path(tmp)
        s, walls = time_default_in_new_processes(max(1, args.repeat))
        print(f"turbgen kaimal 4096 x 11 x 31 x 31 (u, v, w, written to zarr): {s['wall_s']:.2f} s (fastest of "
              f"{', '.join(f'{w:.2f}' for w in walls)}; target <= 2 s); max torus {s['max_torus']}, "
              f"yz clip error {s['yz_clip_error']:g}")
        if not args.skip_pyconturb:
            n1, n2 = (int(v) for v in args.pyconturb_nt.split(","))
            (t1, f1), (t2, f2) = time_pyconturb_plane(n1), time_pyconturb_plane(n2)
            per_f = (t2 - t1) / (f2 - f1)
            fixed = max(t1 - per_f * f1, 0.0)
            full = (fixed + per_f * 2048) * len(DEFAULT_PLANES_M)
            print(f"pyconturb 1 plane 31 x 31 (u, v, w): {t1:.1f} s for nt = {n1} ({f1} frequencies), "
                  f"{t2:.1f} s for nt = {n2} ({f2}) measured -> {fixed:.1f} s fixed + {per_f:.2f} s per frequency")
            print(f"pyconturb 11 planes x 4096 steps: {full / 60:.0f} min EXTRAPOLATED "
                  f"({(fixed + per_f * 2048) / 60:.1f} min per plane x 11; evoTurb's mixing step not included)")
            print(f"ratio pyconturb / turbgen: {full / s['wall_s']:.0f}x (target >= 50x)")
        if not args.skip_64:
            s64 = time_turbgen(64, 4.84375, tmp)
            print(f"turbgen kaimal 4096 x 11 x 64 x 64 (310 m, u, v, w, written to zarr): {s64['wall_s']:.1f} s; "
                  f"max torus {s64['max_torus']}, yz clip error {s64['yz_clip_error']:g} (target: seconds to a minute)")


if __name__ == "__main__":
    main()
