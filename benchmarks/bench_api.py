"""The Python API's Mann fields in memory against the runs layer's synthesis, in one process (issue 28 acceptance).

    python benchmarks/bench_api.py               # default 4D Mann and the 8192 x 64 x 64 box, 3 timed calls each
    python benchmarks/bench_api.py --quick       # nt / 8, to check the script
    python benchmarks/bench_api.py --case box --repeat 5

Cases (the arguments of bench_mann.py's):
  paper  ``turbgen.mann()``: the default 4D field, 4096 x 11 x 64 x 64, y/z padded x2, returned in memory.
  box    ``turbgen.mann(lifetime="mann", L=49, gamma=3.1, evo="frozen", U=16, dt=0.5, nt=8192, ny=64, nz=64,
         dy=4.7, planes=[0], ae=...)``: one Mann-lifetime box, ae for sigma_u = 2.816 m/s.
Against each, in the same process: ``synthesis``, the runs layer's synthesis without any store, as run_mann makes
it (the stencil as run_mann chooses it: on demand for one snapshot, else built; MannSnapshots with run_mann's
threads and two buffers; every plane yielded and dropped). This is the in-memory figure of bench_mann.py's box case
(the paper case of bench_mann.py also writes a store). Both are warm (imports, compiled kernels and a first call
excluded) and timed alternately ``--repeat`` times, with two more references: ``synthesis + the field's memory``
(the synthesis after allocating and writing three float32 arrays of the field's shape: what returning the field
costs whatever computes it) and ``run_mann to a store`` (the store in a temporary directory); the fastest of each
and their ratio to the synthesis are printed (the machine may be shared: ratios within one process are the
comparable figures). The load average is
printed before and after. ``--through-store``: also the field made as turbgen.mann() made it before (a store in a
temporary directory, loaded back).
"""

from __future__ import annotations

import argparse
import os
import time

L_M, GAMMA, DY = 49.0, 3.1, 4.7


def _box_ae() -> float:
    from turbgen.theory.mann_spectra import ae_for_sigma_u
    from turbgen.theory.params import MannParams

    return ae_for_sigma_u(2.816, MannParams(ae=1.0, length_scale_m=L_M, gamma=GAMMA, lifetime="mann"))


def keywords(case: str, nt: int | None) -> dict:
    """The keywords of turbgen.mann for ``case`` ("paper" or "box"), nt [samples] if given."""
    if case == "paper":
        return {} if nt is None else {"nt": nt}
    return {"lifetime": "mann", "L": L_M, "gamma": GAMMA, "evo": "frozen", "U": 16.0, "dt": 0.5,
            "nt": nt or 8192, "ny": 64, "nz": 64, "dy": DY, "planes": [0.0], "ae": _box_ae()}  # fmt: skip


def synthesis(run) -> None:
    """The runs layer's synthesis of ``run`` (turbgen.runs.mann.run_mann without its store): every plane made."""
    from turbgen.resources import default_threads
    from turbgen.runs.mann import build_mann_stencil
    from turbgen.synthesis.mann_spacetime import MannSnapshots
    from turbgen.synthesis.mann_stencil import build_stencil, synthesis_box

    if run.grid.nx == 1 or run.params.evo_time_s is None:
        stencil = build_stencil(run.params, synthesis_box(run), storage="on_demand")
    else:
        stencil = build_mann_stencil(run)
    gen = MannSnapshots(stencil, run.grid.ny, run.grid.nz, default_threads(None), buffers=2)
    for _ in gen.generate(run.seed, run.plane_times_s()):
        pass


def synthesis_keeping(run) -> None:
    """:func:`synthesis` plus the fresh memory of the field the API returns: three float32 arrays of the grid's shape
    allocated and written once (what any function returning the field pays, measured apart from the API's code)."""
    import numpy as np

    field = [np.empty(run.grid.shape, dtype=np.float32) for _ in range(3)]
    for a in field:
        a.fill(0.0)
    synthesis(run)


def store_run(run) -> None:
    """``run_mann`` of ``run`` into a store in a temporary directory (the paper case's figure of bench_mann.py)."""
    import tempfile

    from turbgen.runs.mann import run_mann

    with tempfile.TemporaryDirectory(dir=os.environ.get("BENCH_TMP")) as tmp:
        run_mann(run, os.path.join(tmp, "f.zarr"))


def through_store(kw: dict) -> None:
    """The field as turbgen.mann() made it without ``out`` before it was made in memory: a store in a temporary
    directory, loaded back."""
    import tempfile

    import turbgen

    with tempfile.TemporaryDirectory(dir=os.environ.get("BENCH_TMP")) as tmp:
        turbgen.mann(**kw, out=os.path.join(tmp, "f.zarr")).load()


def measure(case: str, nt: int | None, repeat: int, store: bool) -> dict:
    """Seconds of the API and of the synthesis (and through a store if ``store``), alternating, after one warm
    call of each."""
    import turbgen
    from turbgen.spec.mann import MannRun

    kw = keywords(case, nt)
    ds = turbgen.mann(**kw)  # warm: imports, compiled kernels, first touch of the process's memory
    run = MannRun.from_attrs(ds.attrs)
    del ds
    calls = {"api": lambda: turbgen.mann(**kw), "synthesis": lambda: synthesis(run),
             "synthesis + the field's memory": lambda: synthesis_keeping(run),
             "run_mann to a store": lambda: store_run(run)}  # fmt: skip
    if store:
        calls["through a store (loaded)"] = lambda: through_store(kw)
    for call in list(calls.values())[1:]:
        call()
    seconds = {name: [] for name in calls}
    for _ in range(repeat):
        for name, call in calls.items():
            t0 = time.perf_counter()
            call()
            seconds[name].append(time.perf_counter() - t0)
    return {"seconds": seconds, "grid": f"{run.grid.nt} x {run.grid.nx} x {run.grid.ny} x {run.grid.nz}"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", choices=["paper", "box", "all"], default="all")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="nt / 8")
    parser.add_argument("--through-store", action="store_true",
                        help="also time the field made through a temporary store and loaded (the former path)")
    args = parser.parse_args()
    print(f"load average at the start: {os.getloadavg()[0]:.2f}")
    for case in ("paper", "box") if args.case == "all" else (args.case,):
        nt = None if not args.quick else (512 if case == "paper" else 1024)
        r = measure(case, nt, args.repeat, args.through_store)
        fastest = {name: min(s) for name, s in r["seconds"].items()}
        print(f"{case} ({r['grid']}):")
        for name, s in r["seconds"].items():
            print(f"  {name}: {fastest[name]:.2f} s (of {', '.join(f'{x:.2f}' for x in s)}), "
                  f"ratio to synthesis {fastest[name] / fastest['synthesis']:.2f}")
    print(f"load average at the end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
