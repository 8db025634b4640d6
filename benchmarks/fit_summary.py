"""Coverage table of benchmarks/bench_fit.py's results (JSON lines): per case and fit kind, the fraction of
realisations whose 95 % interval holds the true value, with its binomial standard error sqrt(0.95 0.05 / n), the
median chi2/dof, and per fitted variable (ln ae, ln L, Gamma) the scatter ratio: the standard deviation of the
estimate over the realisations divided by the rms of the fitted standard deviations (1 when the intervals have the
right width; its own standard error is about ratio / sqrt(2 (n - 1))) and the bias: the mean of estimate - truth
(relative for ae and L)."""

from __future__ import annotations

import json
import math
import sys
from collections import defaultdict

NAMES = ("ae", "length_scale_m", "gamma")


def _spread(rs, case, k: int, name: str) -> tuple[float, float]:
    """(scatter ratio, mean error) of parameter ``name`` (index k into the case) over the rows ``rs``."""
    log = name != "gamma"
    dev = [(math.log(r["fit"][name]["value"] / case[k]) if log else r["fit"][name]["value"] - case[k]) for r in rs]
    lo_hi = [r["fit"][name]["ci95"] for r in rs]
    fitted = [(math.log(hi / lo) if log else hi - lo) / 3.92 for lo, hi in lo_hi]
    n = len(dev)
    mean = sum(dev) / n
    scatter = math.sqrt(sum((d - mean) ** 2 for d in dev) / max(n - 1, 1))
    return scatter / math.sqrt(sum(f * f for f in fitted) / n), mean


def main(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    groups = defaultdict(list)
    for r in rows:
        groups[(tuple(r["case"]), r["kind"])].append(r)
    print("| (ae, L, Γ) | fit | n | coverage ae | L | Γ | median χ²/dof | scatter ratio ae, L, Γ | bias ae, L, Γ "
          "| median s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (case, kind), rs in sorted(groups.items()):
        n = len(rs)
        cells = []
        for name in NAMES:
            hits = [r["covered"][name] for r in rs if r["covered"][name] is not None]
            se = math.sqrt(0.95 * 0.05 / max(len(hits), 1))
            cells.append(f"{sum(hits) / len(hits):.0%} ± {se:.0%}" if hits else "held")
        chi = sorted(r["fit"]["chi2_dof"] for r in rs)[n // 2]
        sec = sorted(r["seconds"] for r in rs)[n // 2]
        spread = [_spread(rs, case, k, name) for k, name in enumerate(NAMES)]
        ratios = ", ".join(f"{s:.2f}" for s, _ in spread)
        bias = ", ".join(f"{b:+.1%}" if k < 2 else f"{b:+.2f}" for k, (_, b) in enumerate(spread))
        print(f"| {case} | {kind} | {n} | {' | '.join(cells)} | {chi:.2f} | {ratios} | {bias} | {sec:.1f} |")


if __name__ == "__main__":
    main(sys.argv[1])
