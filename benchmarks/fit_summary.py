"""Coverage table of benchmarks/bench_fit.py's results (JSON lines): per case and fit kind, the fraction of
realisations whose 95 % interval holds the true value, with its binomial standard error, the median chi2/dof, and
for L the scatter ratio: the standard deviation of ln(L_fit / L) over the realisations divided by the rms of the
fitted standard deviations (1 when the intervals have the right width) and the mean of ln(L_fit / L) (the bias)."""

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
    print("| (ae, L, Γ) | fit | n | ae | L | Γ | median χ²/dof | L scatter ratio | L bias | median s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (case, kind), rs in sorted(groups.items()):
        n = len(rs)
        cells = []
        for name in ("ae", "length_scale_m", "gamma"):
            hits = [r["covered"][name] for r in rs if r["covered"][name] is not None]
            se = math.sqrt(0.95 * 0.05 / max(len(hits), 1))
            cells.append(f"{sum(hits) / len(hits):.0%} ± {se:.0%}" if hits else "held")
        chi = sorted(r["fit"]["chi2_dof"] for r in rs)[n // 2]
        sec = sorted(r["seconds"] for r in rs)[n // 2]
        dev = [math.log(r["fit"]["length_scale_m"]["value"] / case[1]) for r in rs]
        fitted = [math.log(r["fit"]["length_scale_m"]["ci95"][1] / r["fit"]["length_scale_m"]["ci95"][0]) / 3.92
                  for r in rs]
        mean = sum(dev) / n
        scatter = math.sqrt(sum((d - mean) ** 2 for d in dev) / max(n - 1, 1))
        ratio = scatter / math.sqrt(sum(f * f for f in fitted) / n)
        print(f"| {case} | {kind} | {n} | {' | '.join(cells)} | {chi:.2f} | {ratio:.2f} | {mean:+.1%} | {sec:.1f} |")


if __name__ == "__main__":
    main(sys.argv[1])
