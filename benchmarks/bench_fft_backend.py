"""The Mann synthesis through the FFT seam (turbgen.fft): the backends against each other, and this code against an
earlier tree (the seam must not slow the default backend down).

    python benchmarks/bench_fft_backend.py                       # pyfftw vs scipy, alternately in one process
    python benchmarks/bench_fft_backend.py --before /tmp/before  # and this tree vs an earlier one, in pairs
    (git archive <commit> | tar -x -C /tmp/before: the tree before the seam)

The case: the default Mann run's synthesis (11 evolving planes, 64 x 64 points, y/z padded x2) at nt = --nt
(default 512, an eighth of the default 4096: the same plans and work per time step), its stencil built once and
excluded; each timing is MannSnapshots.generate over every plane, the planes discarded (no store). Backends: each
repetition times pyfftw then scipy in the same process, new generators each time (their plans included). Trees:
each repetition runs a child process of the earlier tree, then one of this tree (PYTHONPATH), each timing its
generator --inner times and keeping the fastest; the ratios are per pair and their median is printed, so a load
change of the shared machine between pairs cancels out. The machine's load (os.getloadavg) is printed before and
after.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def _stencil(nt: int):
    from turbgen.runs.mann import synthesis_box
    from turbgen.spec.mann import MannRun
    from turbgen.synthesis.mann_stencil import build_stencil

    run = MannRun.from_mapping({"grid": {"nt": nt}})
    return run, build_stencil(run.params, synthesis_box(run))


def _time_generate(run, stencil, **backend) -> float:
    """Seconds of one synthesis of every plane of ``run`` (``backend``: fft_backend=..., on code that has the seam)."""
    from turbgen.synthesis.mann_spacetime import MannSnapshots

    g = run.grid
    t0 = time.perf_counter()
    gen = MannSnapshots(stencil, g.ny, g.nz, buffers=2, **backend)
    for _ in gen.generate(run.seed, run.plane_times_s()):
        pass
    return time.perf_counter() - t0


def backends(nt: int, repeat: int) -> dict:
    run, stencil = _stencil(nt)
    _time_generate(run, stencil)  # compiled kernels and first touches out of the timings
    times: dict[str, list[float]] = {"pyfftw": [], "scipy": []}
    for _ in range(repeat):
        for name in times:
            times[name].append(_time_generate(run, stencil, fft_backend=name))
    ratios = [s / p for p, s in zip(times["pyfftw"], times["scipy"])]
    return {"seconds": times, "scipy_over_pyfftw_median": statistics.median(ratios)}


def child(nt: int, inner: int) -> None:
    run, stencil = _stencil(nt)
    _time_generate(run, stencil)
    print(json.dumps(min(_time_generate(run, stencil) for _ in range(inner))))


def trees(before: str, nt: int, repeat: int, inner: int) -> dict:
    def one(tree: str) -> float:
        env = dict(os.environ, PYTHONPATH=tree)
        env.pop("TURBGEN_FFT_BACKEND", None)  # both trees with their default backend
        out = subprocess.run([sys.executable, __file__, "--child", "--nt", str(nt), "--inner", str(inner)], env=env,
                             capture_output=True, text=True, check=True)  # fmt: skip
        return float(out.stdout.strip().splitlines()[-1])

    pairs = [(one(before), one(str(HERE))) for _ in range(repeat)]
    return {"pairs_before_after_s": pairs, "after_over_before_median": statistics.median(a / b for b, a in pairs)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nt", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=5, help="alternations (pairs)")
    ap.add_argument("--inner", type=int, default=3, help="timings per child process (the fastest counts)")
    ap.add_argument("--before", help="an earlier tree of turbgen (its root) to compare this one with")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        return child(args.nt, args.inner)
    report = {"nt": args.nt, "load_before": os.getloadavg()}
    report["backends"] = backends(args.nt, args.repeat)
    if args.before:
        report["trees"] = trees(args.before, args.nt, args.repeat, args.inner)
    report["load_after"] = os.getloadavg()
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
