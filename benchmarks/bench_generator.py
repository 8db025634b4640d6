"""A warm generator's further seeds against its first field, in one process (issue 36 §1: at most 0.6 x).

    python benchmarks/bench_generator.py                # the default 4D Mann field, 4096 x 11 x 64 x 64, 3 seeds
    python benchmarks/bench_generator.py --quick        # nt / 8, to check the script
    python benchmarks/bench_generator.py --seeds 5

``first``: ``turbgen.MannGenerator(params, grid)`` (the stencil built in memory) and its ``field(seed=1)``: what one
field costs through the generator. ``further``: ``field(seed=k)`` of the same, warm generator, k = 2, 3, ... (the
random coefficients and the transforms only). Each field is dropped before the next is made (the field itself is
2.2 GB). The process is warmed first (imports, compiled kernels) on a small grid, so the first field does not pay
the one-off numba load. Printed: each time, the ratio of the median further seed to the first field, and the load
average before and after (the machine may be shared: the ratio within one process is the comparable figure).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time


def _warm() -> None:
    import turbgen

    g = turbgen.MannGenerator(turbgen.MannParams(ae=0.1, length_scale_m=30, gamma=3.1),
                              turbgen.Grid(nt=64, dt_s=0.5, x_m=(0, 40), ny=8, nz=8, dy_m=8, dz_m=8), pad_yz=1)
    g.field(seed=1)


def _default_generator_inputs(nt: int | None):
    """The default run of ``turbgen mann`` as the generator's params, grid and U (turbgen.spec.defaults)."""
    from turbgen.spec.mann import MannRun

    run = MannRun.from_mapping({} if nt is None else {"grid": {"nt": nt}})
    return run.params, run.grid, run.U_m_s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="nt = 512 instead of 4096")
    parser.add_argument("--seeds", type=int, default=3, help="further seeds timed (default 3)")
    args = parser.parse_args()
    import turbgen

    print(f"load average before: {os.getloadavg()}")
    _warm()
    params, grid, U = _default_generator_inputs(512 if args.quick else None)
    print(f"grid (t, x, y, z) = {grid.shape}, U = {U:g} m/s, ae = {params.ae:.4g}")
    t0 = time.perf_counter()
    g = turbgen.MannGenerator(params, grid, U)
    built = time.perf_counter() - t0
    ds = g.field(seed=1)
    first = time.perf_counter() - t0
    del ds
    print(f"first field: {first:.2f} s (stencil {built:.2f} s, {g.nbytes / 2**30:.2f} GiB)")
    further = []
    for seed in range(2, 2 + args.seeds):
        t0 = time.perf_counter()
        ds = g.field(seed=seed)
        further.append(time.perf_counter() - t0)
        del ds
        print(f"seed {seed}: {further[-1]:.2f} s")
    median = statistics.median(further)
    print(f"further seed / first field: {median / first:.3f} (median {median:.2f} s of {len(further)} / {first:.2f} s)")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
