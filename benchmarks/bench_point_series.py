"""Reading measured point series: a 30-minute 20 Hz 4-sonic mast (u, v, w; 432,000 values) as a point-series JSON
file (``load_point_series``, what ``turbgen fit mann`` and ``--constrain`` read) and in memory
(``turbgen.point_series``), against the anchor of parsing the same file (``json.loads``).

    python benchmarks/bench_point_series.py            # 5 rounds
    python benchmarks/bench_point_series.py --rounds 1

Printed: the fastest round of each, its ratio to the parse, and the load average before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

import turbgen
from turbgen.spec.constraints import load_point_series


def _mast(n: int = 36_000) -> dict:
    rng = np.random.default_rng(1)
    sensors = [{"name": f"sonic {h} m", "x_m": 0, "y_m": 0, "height_m": h,
                **{f"{c}_m_s": (rng.standard_normal(n) + (10 if c == "u" else 0)).round(3).tolist() for c in "uvw"}}
               for h in (70.5, 82.5, 94.5, 106.5)]  # fmt: skip
    return {"kind": "point-series", "total_wind": True, "time_s": (np.arange(n) * 0.05).round(3).tolist(),
            "sensors": sensors}


def _fastest(f, rounds: int) -> float:
    best = float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    rounds = ap.parse_args().rounds
    data = _mast()
    arrays = [{k: np.array(v, dtype=float) if k.endswith("_m_s") else v for k, v in s.items()} for s in data["sensors"]]
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "mast.json"
        path.write_text(json.dumps(data))
        parse = _fastest(lambda: json.loads(path.read_text()), rounds)
        file = _fastest(lambda: load_point_series(path), rounds)
    memory = _fastest(lambda: turbgen.point_series(np.array(data["time_s"]), arrays, total_wind=True), rounds)
    print(f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after; fastest of {rounds}")
    for name, t in (("json.loads (anchor)", parse), ("load_point_series (file)", file),
                    ("turbgen.point_series (memory)", memory)):
        print(f"{name:32s} {t:7.3f} s  {t / parse:6.2f} x parse")


if __name__ == "__main__":
    main()
