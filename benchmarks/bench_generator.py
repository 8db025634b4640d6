"""A warm generator's further seeds against its first field, in one process (issue 36 §1: at most 0.6 x).

    python benchmarks/bench_generator.py                # the default 4D Mann field, 4096 x 11 x 64 x 64, 3 seeds
    python benchmarks/bench_generator.py --quick        # nt / 8, to check the script
    python benchmarks/bench_generator.py --seeds 5
    python benchmarks/bench_generator.py --model kaimal  # the default Kaimal field, 4096 x 11 x 31 x 31

``first``: ``turbgen.MannGenerator(params, grid)`` (the stencil built in memory) and its ``field(seed=1)``: what one
field costs through the generator. ``further``: ``field(seed=k)`` of the same, warm generator, k = 2, 3, ... (the
random coefficients and the transforms only). Each field is dropped before the next is made (the field itself is
2.2 GB). The process is warmed first (imports, compiled kernels of both models) on a small grid, so the first field
does not pay the one-off numba load. Printed: each time and its CPU (user + sys, all threads), the ratio of the median
further seed to the first field in both, and the load average before and after (on a shared machine the CPU ratio is
the comparable figure).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import time


def _cpu() -> float:
    """User + system CPU [s] of this process, all threads (the comparable figure on a loaded machine)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _warm() -> None:
    import turbgen

    g = turbgen.MannGenerator(turbgen.MannParams(ae=0.1, length_scale_m=30, gamma=3.1),
                              turbgen.Grid(nt=64, dt_s=0.5, x_m=(0, 40), ny=8, nz=8, dy_m=8, dz_m=8), pad_yz=1)
    g.field(seed=1)
    turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 40])


def _default_generator(model: str, nt: int | None):
    """The generator of the default run of ``turbgen mann`` / ``turbgen kaimal`` (turbgen.spec.defaults)."""
    import turbgen
    from turbgen.spec.kaimal import KaimalRun
    from turbgen.spec.mann import MannRun

    run = (MannRun if model == "mann" else KaimalRun).from_mapping({} if nt is None else {"grid": {"nt": nt}})
    if model == "mann":
        return turbgen.MannGenerator(run.params, run.grid, run.U_m_s)
    return turbgen.KaimalGenerator(run.kaimal, run.grid, run.U_m_s, hub_height_m=run.hub_height_m)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="nt = 512 instead of 4096")
    parser.add_argument("--seeds", type=int, default=3, help="further seeds timed (default 3)")
    parser.add_argument("--model", choices=("mann", "kaimal"), default="mann", help="the generator (default mann)")
    args = parser.parse_args()

    print(f"load average before: {os.getloadavg()}")
    _warm()
    t0, c0 = time.perf_counter(), _cpu()
    g = _default_generator(args.model, 512 if args.quick else None)
    built = time.perf_counter() - t0
    print(f"{args.model}: grid (t, x, y, z) = {g.grid.shape}")
    ds = g.field(seed=1)
    first, first_cpu = time.perf_counter() - t0, _cpu() - c0
    del ds
    print(f"first field: {first:.2f} s, CPU {first_cpu:.2f} s (constructor {built:.2f} s)")
    further, cpu = [], []
    for seed in range(2, 2 + args.seeds):
        t0, c0 = time.perf_counter(), _cpu()
        ds = g.field(seed=seed)
        further.append(time.perf_counter() - t0)
        cpu.append(_cpu() - c0)
        del ds
        print(f"seed {seed}: {further[-1]:.2f} s, CPU {cpu[-1]:.2f} s")
    median = statistics.median(further)
    print(f"further seed / first field: {median / first:.3f} (median {median:.2f} s of {len(further)} / {first:.2f} s); "
          f"in CPU {statistics.median(cpu) / first_cpu:.3f}")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
