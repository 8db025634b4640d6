"""Out-of-core Mann box: make a field larger than memory under a budget, time it, check its spectra, delete it.

    python benchmarks/bench_outofcore.py                          # 16384 x 512 x 256, --memory 4GiB (~60 GB of disk)
    python benchmarks/bench_outofcore.py --nt 2048 --ny 128 --nz 64 --memory 512MiB   # a quick check
    python benchmarks/bench_outofcore.py --check-only STORE       # only the spectra of an existing store

The run is `turbgen mann --planes 0 --evo frozen --lifetime mann` in a subprocess; its wall time and peak
RSS (VmHWM of that process) are printed with the machine's load. The check reads every 16th point in y
and z over the whole record, averages the one-sided periodograms of u, v, w over the points and over
log-spaced k1 bands, and prints them beside the model one-point spectra F_ii(k1) (Mann 1994, Eq. 8 of
Guo et al. 2022; theory.mann_spectra.one_point_spectra) and the field's sigma beside the model's.
The discrete box lacks energy at k1 near its own low- and high-wavenumber limits (README, Mann section),
so the bands printed run from 3 dk2 to k_N / 13, where the box and the model agree within a few %.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

HWM = (
    "import sys\nfrom turbgen.cli import cli\ntry:\n    cli.main(sys.argv[1:], standalone_mode=False)\nfinally:\n"
    "    print('VmHWM', open('/proc/self/status').read().split('VmHWM:')[1].split()[0], file=sys.stderr)\n"
)


def check_spectra(path: str, stride: int = 16) -> None:
    from turbgen.store import open_store
    from turbgen.theory.mann_spectra import one_point_spectra, variances
    from turbgen.theory.params import MannParams

    fs = open_store(path)
    p = fs.attrs["parameters"]
    params = MannParams(ae=p["ae"], length_scale_m=p["length_scale_m"], gamma=p["gamma"], lifetime=p["lifetime"],
                        factor1=p["factor1"], factor2=p["factor2"], evo_time_s=None)  # fmt: skip
    g = fs.grid
    dx = fs.U_m_s * g.dt_s
    k1 = 2 * np.pi * np.fft.rfftfreq(g.nt, d=dx)
    t0 = time.perf_counter()
    measured = {}
    for c in "uvw":
        arr = fs.array(c)
        chunk = arr.chunks[0]
        x = np.empty((g.nt, len(range(0, g.ny, stride)), len(range(0, g.nz, stride))), np.float32)
        for a in range(0, g.nt, chunk):
            x[a : a + chunk] = arr[a : a + chunk, 0, ::stride, ::stride]
        x = x.reshape(g.nt, -1).astype(float)
        x -= x.mean(axis=0)
        spec = np.abs(np.fft.rfft(x, axis=0)) ** 2  # one-sided F(k1) = 2 |X|^2 dx / (2 pi n) per point
        measured[c] = (2 * spec * dx / (2 * np.pi * g.nt)).mean(axis=1)
        measured[f"sigma_{c}"] = float(np.sqrt((x * x).mean()))
    print(f"read {path} ({g.nt} x {g.ny} x {g.nz}, every {stride}th point in y and z) in {time.perf_counter() - t0:.0f} s")
    dk2 = 2 * np.pi / (2 * g.ny * g.dy_m)  # the synthesis box is padded x2 by default
    k_lo, k_hi = 3 * dk2, np.pi / g.dy_m / 13
    edges = np.geomspace(k_lo, k_hi, 9)
    centers = np.sqrt(edges[:-1] * edges[1:])
    lines = (k1 >= k_lo) & (k1 < edges[-1])
    model = one_point_spectra(k1[lines], params)  # at every line of the bands
    print(" k1 [rad/m]   " + "   ".join(f"F_{c}{c} field/model" for c in "uvw"))
    for n, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        sel = (k1 >= a) & (k1 < b)
        ratios = []
        for i, c in enumerate("uvw"):
            # band averages of the field and of the model over the same lines
            m = 2 * model[f"F{i + 1}{i + 1}"][sel[lines]]  # one-sided model: 2 F_ii
            ratios.append(measured[c][sel].mean() / m.mean())
        print(f" {centers[n]:.4f}       " + "        ".join(f"{r:6.3f}" for r in ratios) + f"   ({sel.sum()} lines)")
    var = variances(params)
    print("sigma field / model: " + ", ".join(
        f"{c} {measured[f'sigma_{c}']:.3f} / {np.sqrt(var[c + c]):.3f} m/s" for c in "uvw"))  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nt", type=int, default=16384)
    ap.add_argument("--ny", type=int, default=512)
    ap.add_argument("--nz", type=int, default=256)
    ap.add_argument("--memory", default="4GiB")
    ap.add_argument("--dir", default=None, help="where the store and scratch go (default: a temporary directory here)")
    ap.add_argument("--check-only", metavar="STORE")
    args = ap.parse_args()
    if args.check_only:
        check_spectra(args.check_only)
        return
    where = tempfile.mkdtemp(prefix="bench-outofcore-", dir=args.dir or ".")
    try:
        out = os.path.join(where, "box.zarr")
        cmd = ["mann", "--nt", str(args.nt), "--ny", str(args.ny), "--nz", str(args.nz), "--planes", "0", "--evo",
               "frozen", "--lifetime", "mann", "--memory", args.memory, "--out", out]  # fmt: skip
        print(f"load average {' / '.join(f'{x:.2f}' for x in os.getloadavg())}; turbgen {' '.join(cmd)}")
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", HWM, *cmd], capture_output=True, text=True)
        wall = time.perf_counter() - t0
        print(proc.stdout.strip())
        if proc.returncode != 0:
            print(proc.stderr.strip().splitlines()[-1])
            return
        hwm = int(proc.stderr.split("VmHWM")[1].split()[0]) / 2**20
        print(f"wall {wall:.0f} s, peak RSS (VmHWM) {hwm:.2f} GiB; load average after "
              f"{' / '.join(f'{x:.2f}' for x in os.getloadavg())}")  # fmt: skip
        check_spectra(out)
    finally:
        shutil.rmtree(where, ignore_errors=True)


if __name__ == "__main__":
    main()
