"""Where a lidar-constrained Mann run spends its time, phase by phase, on a grid of your choice.

    python benchmarks/constrain_phases.py WORKDIR                      # the default grid: 4096 x 11 x 64 x 64
    python benchmarks/constrain_phases.py WORKDIR --nt 512 --ny 16 --dy 8

WORKDIR receives the truth (seed 1, IEC class A given explicitly) and its virtual-lidar record (the Table 3 lidar,
`turbgen.lidar`) unless they are there already; then seed 2 is conditioned on that record step by step as
turbgen.runs.constrain does it (placing, stencil, the per-frequency system S, pass 1, the solve, the correction,
pass 2 without adding), each step's wall time printed. Then, in the same process, end to end: the plain run
(turbgen.runs.mann.run_mann) and the conditional sample (run_mann_constrained, with its store), and their ratio.
``--missing F``: a fraction F of the line-of-sight samples (chosen at random, seed 0) is removed first (issue 26's
"20 % missing" case: conjugate gradients instead of the direct solve). The end-to-end cases in new processes are
timed as in benchmarks/constrain.md.
"""

from __future__ import annotations

import argparse
import shutil
import time
from pathlib import Path

import numpy as np

import turbgen
from turbgen.runs.constrain import (PlacedData, load_constraints, measurement_noise, place, run_mann_constrained,
                                    solve_constraints, stream_system, unconstrained_measurement)  # fmt: skip
from turbgen.runs.mann import build_mann_stencil, run_mann
from turbgen.spec.mann import MannRun
from turbgen.synthesis import conditioning as cond
from turbgen.synthesis.mann_spacetime import MannSnapshots


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workdir", type=Path)
    ap.add_argument("--nt", type=int, default=4096)
    ap.add_argument("--ny", type=int, default=64)
    ap.add_argument("--dy", type=float, default=4.7)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--missing", type=float, default=0.0, help="fraction of the samples removed at random")
    a = ap.parse_args()
    w = a.workdir
    w.mkdir(exist_ok=True)
    common = dict(nt=a.nt, ny=a.ny, nz=a.ny, dy=a.dy, gates="50:170:13.3", config={"turb_class": "A"})
    if not (w / "truth_lidar.zarr").exists():
        turbgen.mann(seed=1, out=w / "truth.zarr", overwrite=True, **common)
        turbgen.lidar(w / "truth.zarr", out=w / "truth_lidar.zarr")
    run = MannRun.from_mapping({"grid": {"nt": a.nt, "ny": a.ny, "nz": a.ny, "dy_m": a.dy}, "turb_class": "A",
                                "seed": 2})  # fmt: skip
    t0 = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal t0
        print(f"{name:<34} {time.perf_counter() - t0:7.2f} s", flush=True)
        t0 = time.perf_counter()

    files = load_constraints([w / "truth_lidar.zarr"])
    placed = place(run, files)
    if a.missing:
        data = placed.data.copy()
        data[np.random.default_rng(0).random(data.shape) < a.missing] = np.nan
        placed = PlacedData(placed.streams, data, placed.noise_m_s, placed.geometry)
    lap(f"place ({placed.streams.n_streams} streams, {np.isfinite(placed.data).sum()} samples)")
    stencil = build_mann_stencil(run, None)
    lap("stencil")
    cov = stream_system(run, stencil, placed, a.threads)
    lap("system S")
    g = run.grid
    gen = MannSnapshots(stencil, g.ny, g.nz, a.threads)
    measured = unconstrained_measurement(run, stencil, placed, a.threads)
    lap("pass 1 (generate, measure u_s)")
    x, report = solve_constraints(cov, placed, measured, measurement_noise(run, placed))
    lap(f"solve ({report.method}, {report.iterations} it.)")
    for _ in cond.correction_blocks(stencil, placed.streams, x, run.plane_times_s(), list(range(g.nx)), g.ny, g.nz,
                                    a.threads):  # fmt: skip
        pass
    lap("correction C H^T w")
    for _ in gen.generate(run.seed, run.plane_times_s()):
        pass
    lap("pass 2 (generate only)")
    total = {}
    for name, make in (("plain", lambda out: run_mann(run, out, threads=a.threads)),
                       ("sample", lambda out: run_mann_constrained(run, out, files, threads=a.threads, placed=placed))):
        out = w / f"phases_{name}.zarr"
        shutil.rmtree(out, ignore_errors=True)
        t = time.perf_counter()
        make(out)
        total[name] = time.perf_counter() - t
        shutil.rmtree(out)
        print(f"end to end: {name:<22} {total[name]:7.2f} s", flush=True)
    print(f"sample / plain                     {total['sample'] / total['plain']:7.2f}")


if __name__ == "__main__":
    main()
