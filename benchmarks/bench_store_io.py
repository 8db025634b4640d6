"""A field store written and read through zarr's public API against the raw-chunk path (direct I/O), alternately.

    python benchmarks/bench_store_io.py                 # the default field, 4096 x 11 x 64 x 64 x 3 (2.2 GB)
    python benchmarks/bench_store_io.py --nt 512 --repeat 1

Both paths are the store's own functions (``StoreWriter.write`` and ``FieldStore.read_span``), switched by
``turbgen.store.chunk_files.RAW`` (the setting of the test that compares their bytes). ``write``: every plane of
u, v, w (one random plane reused) and the publish; ``flush``: fsync of every file afterwards (a buffered write
leaves that work to the kernel's writeback, a direct one has done it); ``read``: every plane back into one reused
buffer, cold (each file's pages dropped with posix_fadvise first). Wall and process CPU (all threads, user +
kernel) per step; the machine may be shared, so compare the two paths within one run only.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np


def _files(root: Path):
    return [p for p in root.rglob("*") if p.is_file()]


def _timed(fn) -> tuple[float, float]:
    w, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w, time.process_time() - c


def _flush_and_drop(root: Path) -> None:
    for p in _files(root):
        fd = os.open(p, os.O_RDONLY)
        try:
            os.fsync(fd)
            os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
        finally:
            os.close(fd)


def one(raw: bool, grid, plane: np.ndarray, tmp: Path) -> dict:
    from turbgen.store import chunk_files
    from turbgen.store.reader import open_store
    from turbgen.store.writer import create_store

    chunk_files.RAW = raw
    path = tmp / f"{'raw' if raw else 'zarr'}.zarr"
    attrs = {"model": "kaimal", "parameters": {"U_m_s": 10.0}, "units": {"U_m_s": "m s-1"}, "seed": 1,
             "U_m_s": 10.0, "hub_height_m": 90.0}

    def write():
        with create_store(path, grid, attrs) as w:
            for c in ("u", "v", "w"):
                for ix in range(grid.nx):
                    w.write(c, ix, plane)

    def read():
        fs, buf = open_store(path), chunk_files.empty_aligned(plane.shape)
        for c in ("u", "v", "w"):
            for ix in range(grid.nx):
                fs.read_span(c, ix, 0, grid.nt, out=buf)

    out = {"write": _timed(write), "flush": _timed(lambda: _flush_and_drop(path)), "read": _timed(read)}
    shutil.rmtree(path)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nt", type=int, default=4096)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    from turbgen.grid import Grid
    from turbgen.store.block_sums import block_sums

    grid = Grid(nt=args.nt, dt_s=0.5, x_m=tuple(np.linspace(0.0, 400.0, 11)), ny=64, nz=64, dy_m=4.0, dz_m=4.0)
    plane = np.random.default_rng(1).standard_normal((grid.nt, grid.ny, grid.nz)).astype(np.float32)
    block_sums(plane)  # compiled before timing
    print(f"grid (t, x, y, z) = {grid.shape} x 3 components, {3 * grid.nbytes_per_component() / 1e9:.2f} GB; "
          f"load average {os.getloadavg()} at start")
    rows = {True: [], False: []}
    with tempfile.TemporaryDirectory(dir=os.environ.get("BENCH_DIR")) as tmp:
        for r in range(args.repeat):
            for raw in (True, False) if r % 2 == 0 else (False, True):
                res = one(raw, grid, plane, Path(tmp))
                rows[raw].append(res)
                print(f"  {'raw ' if raw else 'zarr'}: " + ", ".join(
                    f"{k} {w:.2f} s wall / {c:.2f} s CPU" for k, (w, c) in res.items()), flush=True)
    print(f"load average {os.getloadavg()} at end; medians (zarr / raw):")
    for k in ("write", "flush", "read"):
        med = {raw: [float(np.median([x[k][i] for x in rows[raw]])) for i in (0, 1)] for raw in rows}
        print(f"  {k}: raw {med[True][0]:.2f} s wall {med[True][1]:.2f} s CPU; zarr {med[False][0]:.2f} s wall "
              f"{med[False][1]:.2f} s CPU; ratio wall {med[False][0] / med[True][0]:.2f}, "
              f"CPU {med[False][1] / max(med[True][1], 1e-9):.2f}")


if __name__ == "__main__":
    main()
