"""Benchmark of `turbgen validate` on the default Mann store (target: well under a minute on 2 cores).

    python benchmarks/bench_validate.py                     # generate the default store, validate it
    python benchmarks/bench_validate.py --store PATH        # validate an existing store (any model)
    python benchmarks/bench_validate.py --quick             # 1024 x 3 x 32 x 32, to check the script

The store is generated (if needed) in its own subprocess; the validation runs in another
subprocess so that its wall time and peak RSS (ru_maxrss) are its own. Printed: one JSON line
with the wall time, the CPU time of all threads, the split estimate / theory / verdict (the theory
runs in its own thread while the store is read, so its seconds overlap the estimate's), the 1-minute
load average at the end (a loaded machine stretches the wall time), the peak RSS, the store size and
the verdict; then the wall time of validating the store again in the same process, as the next seed of a
sweep is (``again_wall_s``: the predictions are kept, turbgen.validation.theory_cache); and the wall time of the
command `turbgen validate --json STORE` in a new process (``cli_wall_s``: what a user waits for, process start and
imports included). The uncompressed default field is 3 x 738 MiB; the validator reads it chunk by chunk
(one task per plane and span of time chunks), so its memory follows the chunks, not the field.
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

GENERATE = """
import sys
from turbgen.runs.mann import run_mann
from turbgen.spec.mann import MannRun
grid = {quick}
run = MannRun.from_mapping({{"grid": grid}} if grid else {{}})
run_mann(run, sys.argv[1])
"""

VALIDATE = """
import json, os, resource, sys, time
from turbgen.validation import validate
t0, c0 = time.perf_counter(), time.process_time()
r = validate(sys.argv[1], rotor_radius_m=float(sys.argv[2]))
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
t1 = time.perf_counter()
again = validate(sys.argv[1], rotor_radius_m=float(sys.argv[2]))  # as for the next seed of a sweep: theory kept
again_wall = round(time.perf_counter() - t1, 2)
g = r.store.grid
print(json.dumps({
    "store": str(r.store.path), "model": r.store.model, "shape_t_x_y_z": list(g.shape),
    "chunk_t": r.store.chunk_t, "wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "load_1min": os.getloadavg()[0],
    "estimate_s": round(r.seconds["estimate"], 2), "theory_s": round(r.seconds["theory"], 2),
    "verdict_s": round(r.seconds["verdict"], 2),
    "peak_rss_mib": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    "field_mib_uncompressed": round(3 * g.nbytes_per_component() / 2**20, 1),
    "passed": r.passed, "failed": r.failed,
    "again_wall_s": again_wall, "again_theory_kept": again.seconds["theory_kept"],
}))
"""


def console_script() -> str:
    """The ``turbgen`` command of this interpreter's environment (its bin/: no need to activate it), else PATH's."""
    return shutil.which("turbgen", path=os.path.dirname(sys.executable)) or "turbgen"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--store", help="validate this store instead of generating the default Mann store")
    ap.add_argument("--quick", action="store_true", help="small grid (checks the script)")
    ap.add_argument("--rotor-radius", type=float, default=None, help="rotor radius [m] (default 63, quick 40)")
    args = ap.parse_args()
    radius = args.rotor_radius or (40.0 if args.quick else 63.0)
    with tempfile.TemporaryDirectory(prefix="bench_validate_") as tmp:
        store = args.store
        if store is None:
            store = str(Path(tmp) / "mann_default.zarr")
            quick = ({"nt": 1024, "x_m": [0.0, 50.0, 63.3], "ny": 32, "nz": 32, "dy_m": 4.8, "dz_m": 4.8}
                     if args.quick else None)
            subprocess.run([sys.executable, "-c", GENERATE.format(quick=repr(quick)), store], check=True)
        out = subprocess.run([sys.executable, "-c", VALIDATE, store, str(radius)], check=True,
                             capture_output=True, text=True)
        result = json.loads(out.stdout.strip().splitlines()[-1])
        # what a user waits for: the command, process start and imports included (exit 1 = a metric failed)
        t0 = time.perf_counter()
        cli = subprocess.run([console_script(), "validate", "--json", "--rotor-radius", str(radius), store],
                             capture_output=True, text=True)
        result["cli_wall_s"] = round(time.perf_counter() - t0, 2) if cli.returncode in (0, 1) else None
        print(json.dumps(result))


if __name__ == "__main__":
    main()
