"""Benchmark of constrained Mann runs (`turbgen mann --constrain`) against the unconstrained run of the same grid.

    python benchmarks/bench_constrain.py            # 1024 x 11 planes x 32 x 32 (the default planes and spacing)
    python benchmarks/bench_constrain.py --quick    # 256 x 3 planes x 8 x 8, to check the script

Cases, each `turbgen mann` in its own subprocess (wall time and peak RSS of that process, ru_maxrss):
  plain   the unconstrained field of seed 2;
  mast    seed 2 conditioned on a hub-height sonic (u, v, w at 20 Hz, interpolated onto dt) and a second mast
          point 40 m to the side at the rotor plane, zero noise, taken from the field of seed 1;
  gaps    the same with 20 % of the sonic's samples missing at random (conjugate gradients);
  lidar   seed 2 conditioned on the virtual-lidar record of seed 1 (the default 4-beam pulsed lidar of Guo et al.
          2023, Table 3; `turbgen lidar run --out`), zero noise.
Printed: time and memory of each, their ratio to `plain`, the solver's iterations and the largest |field - data| at
the measurements (the store's `constraints` record).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np


# the child prints its own peak RSS (ru_maxrss of RUSAGE_CHILDREN would be the largest of all children so far)
_CHILD = """import resource, sys
from turbgen.cli import main
try:
    main()
except SystemExit as exc:
    code = exc.code
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)
sys.exit(code)
"""


def _turbgen(args: list[str]) -> tuple[float, float]:
    """Run `turbgen ARGS` in a subprocess: (wall time [s], peak RSS of that process [MiB])."""
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-c", _CHILD, *args], check=True, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True)  # fmt: skip
    wall = time.perf_counter() - t0
    return wall, int(res.stderr.strip().splitlines()[-1]) / 1024.0


def _mast_file(store: str, path: str, hub_height_m: float, gaps: bool) -> None:
    from turbgen.store import open_store

    fs = open_store(store)
    g = fs.grid
    t_field = g.t()
    t = np.arange(0.0, t_field[-1], 0.05)  # 20 Hz sonic, linearly interpolated from the truth's stored samples
    iy, iz = g.ny // 2, g.nz // 2
    sensors = []
    for name, y_index in (("hub", iy), ("side", max(iy - int(round(40.0 / g.dy_m)), 0))):
        s = {"name": name, "x_m": 0.0, "y_m": float(g.y()[y_index]), "height_m": hub_height_m + float(g.z()[iz])}
        for c in "uvw" if name == "hub" else "u":
            v = np.interp(t, t_field, fs.read_plane(c, 0)[:, y_index, iz].astype(float))
            if gaps and name == "hub":
                v[np.random.default_rng(0).random(v.size) < 0.2] = np.nan
            s[f"{c}_m_s"] = [None if np.isnan(x) else float(x) for x in v]
        sensors.append(s)
    with open(path, "w") as f:
        json.dump({"kind": "point-series", "time_s": t.tolist(), "sensors": sensors}, f)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    opt = ap.parse_args()
    grid = (["--nt", "256", "--ny", "8", "--nz", "8", "--dy", "10", "--planes", "0,50,63.3"] if opt.quick
            else ["--nt", "1024", "--ny", "32", "--nz", "32"])  # fmt: skip
    print(f"load average {os.getloadavg()}")
    with tempfile.TemporaryDirectory(dir=".") as d:
        truth, lidar = os.path.join(d, "truth.zarr"), os.path.join(d, "truth_lidar.zarr")
        _turbgen(["mann", *grid, "--seed", "1", "--out", truth])
        lidar_args = ["--lidar", os.path.join(d, "lidar.json")] if opt.quick else []
        if opt.quick:
            with open(os.path.join(d, "lidar.json"), "w") as f:
                json.dump({"kind": "pulsed", "mount": "nacelle", "ranges_m": [50, 63.3], "beam_rate_hz": 4.0,
                           "rotor_radius_m": 20, "azimuth_deg": [5, -5], "elevation_deg": [5, -5],
                           "fwhm_m": 10}, f)  # fmt: skip
        subprocess.run([sys.executable, "-c", "from turbgen.cli import main; main()", "lidar", "run", truth,
                        *lidar_args, "--out", lidar], stdout=subprocess.DEVNULL)  # exit 1 = coherence verdict
        for gaps in (False, True):
            _mast_file(truth, os.path.join(d, f"mast{int(gaps)}.json"), 150.0, gaps)
        cases = {
            "plain": [],
            "mast": ["--constrain", os.path.join(d, "mast0.json")],
            "gaps": ["--constrain", os.path.join(d, "mast1.json")],
            "lidar": ["--constrain", lidar],
        }
        results = {}
        for name, extra in cases.items():
            out = os.path.join(d, f"{name}.zarr")
            wall, rss = _turbgen(["mann", *grid, "--seed", "2", "--threads", "2", *extra, "--out", out])
            from turbgen.store import open_store

            record = open_store(out).attrs.get("constraints")
            results[name] = (wall, rss, record)
        base_wall, base_rss, _ = results["plain"]
        print(f"{'case':6s} {'time s':>8s} {'x plain':>8s} {'peak MiB':>9s} {'x plain':>8s}  solver")
        for name, (wall, rss, record) in results.items():
            solver = "" if record is None else (
                f"{record['solver']['method']} {record['solver']['iterations']} it., "
                f"{len(record['streams'])} streams, max |field - data| {record['residual_max_m_s']:.1e} m/s")
            print(f"{name:6s} {wall:8.1f} {wall / base_wall:8.2f} {rss:9.0f} {rss / base_rss:8.2f}  {solver}")
    print(f"load average {os.getloadavg()}")


if __name__ == "__main__":
    main()
