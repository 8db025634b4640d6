"""Benchmark of the virtual lidar on the default Mann store (target <= 10 s, memory bounded by chunks).

    python benchmarks/bench_lidar.py --store PATH       # an existing store (default `turbgen mann` size)
    python benchmarks/bench_lidar.py                     # generate the default store first (minutes)

Runs in a subprocess so that wall time and peak RSS (VmHWM) are the lidar's own. Printed: one JSON
line with the sampling + signals + Welch time (run_lidar), the theory time (store_theory), the peak
RSS and, as the anchor, the time to read the rotor plane's u once (the least any u_RR needs).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

GENERATE = """
import sys
from turbgen.runs.mann import run_mann
from turbgen.spec.mann import MannRun
run_mann(MannRun.from_mapping({}), sys.argv[1])
"""

RUN = """
import json, sys, time
import numpy as np
from turbgen.store import open_store
from turbgen.virtual_lidar.description import load_lidar
from turbgen.virtual_lidar.run import run_lidar
from turbgen.virtual_lidar.report import store_theory
fs = open_store(sys.argv[1])
t0 = time.perf_counter()
for t in range(0, fs.grid.nt, fs.chunk_t):
    np.asarray(fs.array("u")[t : t + fs.chunk_t, 0])
anchor = time.perf_counter() - t0
d = load_lidar("nacelle-4beam")
t0 = time.perf_counter()
r = run_lidar(fs, d)
lidar = time.perf_counter() - t0
t0 = time.perf_counter()
store_theory(fs, d, r.welch["f_hz"][1:-1], r.rotor_radius_m, r.welch["setup"])
theory = time.perf_counter() - t0
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]
print(json.dumps({"shape_t_x_y_z": list(fs.grid.shape), "run_lidar_s": round(lidar, 2), "theory_s": round(theory, 2),
                  "read_rotor_plane_u_s": round(anchor, 2), "ratio_to_anchor": round(lidar / anchor, 1),
                  "peak_rss_mib": round(int(hwm) / 1024), "simulated": r.simulated}))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--store", help="existing store (default: generate the default Mann store in a temp dir)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        store = a.store
        if store is None:
            store = str(Path(tmp) / "mann.zarr")
            subprocess.run([sys.executable, "-c", GENERATE, store], check=True)
        subprocess.run([sys.executable, "-c", RUN, store], check=True)


if __name__ == "__main__":
    main()
