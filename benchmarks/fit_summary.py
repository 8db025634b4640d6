"""Coverage table of benchmarks/bench_fit.py's results (JSON lines): per case and fit kind, the fraction of
realisations whose 95 % interval holds the true value, with its binomial standard error, and the median chi2/dof."""

from __future__ import annotations

import json
import math
import sys
from collections import defaultdict


def main(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    groups = defaultdict(list)
    for r in rows:
        groups[(tuple(r["case"]), r["kind"])].append(r)
    print("| (ae, L, Γ) | fit | n | ae | L | Γ | median χ²/dof | median s |")
    print("|---|---|---|---|---|---|---|---|")
    for (case, kind), rs in sorted(groups.items()):
        n = len(rs)
        cells = []
        for name in ("ae", "length_scale_m", "gamma"):
            hits = [r["covered"][name] for r in rs if r["covered"][name] is not None]
            se = math.sqrt(0.95 * 0.05 / max(len(hits), 1))
            cells.append(f"{sum(hits) / len(hits):.0%} ± {se:.0%}" if hits else "held")
        chi = sorted(r["fit"]["chi2_dof"] for r in rs)[n // 2]
        sec = sorted(r["seconds"] for r in rs)[n // 2]
        print(f"| {case} | {kind} | {n} | {' | '.join(cells)} | {chi:.2f} | {sec:.1f} |")


if __name__ == "__main__":
    main(sys.argv[1])
