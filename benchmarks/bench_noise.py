"""This tree's noise kernel (``fill_normals``: SFC64 + float32 Ziggurat) against an older revision's, in one process.

    python benchmarks/bench_noise.py --against c2e1254           # 5e7 normals, 1 and 2 threads, 7 rounds
    python benchmarks/bench_noise.py --against c2e1254 --n 1e6   # to check the script

The older kernel is the revision's ``turbgen/synthesis/ziggurat_normals.py`` (``git show``) imported from a
temporary directory. Both fill the same stream (equal bits are checked first), alternating round by round; each
round times one call per thread on its own buffer (warm, touched before). Printed: the fastest round's thread CPU time
per normal, and the load average before and after (on a shared machine only the ratio compares).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from turbgen.synthesis.sfc64 import key_words
from turbgen.synthesis.ziggurat_normals import fill_normals


def _revision_kernel(rev: str, tmp: str):
    """``fill_normals`` of revision ``rev``, imported from a copy of its module in ``tmp``."""
    src = subprocess.run(["git", "show", f"{rev}:turbgen/synthesis/ziggurat_normals.py"], check=True,
                         capture_output=True, text=True).stdout  # fmt: skip
    path = os.path.join(tmp, "ziggurat_old.py")
    with open(path, "w") as f:
        f.write(src)
    spec = importlib.util.spec_from_file_location("ziggurat_old", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.fill_normals


def _round(fill, outs: list[np.ndarray], words: np.ndarray) -> float:
    """The threads' mean CPU time [s] of one call each, made together (thread_time: less swayed by load than wall)."""

    def call(out: np.ndarray) -> float:
        t0 = time.thread_time()
        fill(words, out)
        return time.thread_time() - t0

    with ThreadPoolExecutor(len(outs)) as pool:
        return float(np.mean(list(pool.map(call, outs))))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--against", required=True, help="git revision of the older kernel")
    ap.add_argument("--n", type=float, default=5e7, help="normals per call")
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args()
    n, words = int(args.n), key_words((1, 2, 3))
    print(f"load average {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        kernels = {args.against: _revision_kernel(args.against, tmp), "tree": fill_normals}
        outs = [np.ones(n, np.float32) for _ in range(2)]
        ref = kernels[args.against](words, np.empty(n, np.float32))
        assert np.array_equal(fill_normals(words, outs[0]).view(np.uint32), ref.view(np.uint32)), "bits differ"
        for threads in (1, 2):
            best = dict.fromkeys(kernels, np.inf)
            for _ in range(args.rounds):
                for name, fill in kernels.items():
                    best[name] = min(best[name], _round(fill, outs[:threads], words))
            print(f"{threads} thread(s): " + ", ".join(f"{k} {v / n * 1e9:.3f} ns/normal" for k, v in best.items())
                  + f"; tree / {args.against} = {best['tree'] / best[args.against]:.3f}")
    print(f"load average {os.getloadavg()}")


if __name__ == "__main__":
    sys.exit(main())
