"""The outcome of a sweep: the record of every planned run, and its plain-text summary table."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class SweepResult:
    """Records of every planned run (manifest order) and what this invocation did: runs generated (``ran``) and kept
    (``skipped``), wall time [s], names of the runs not complete."""

    out: Path
    records: list[dict]
    ran: int = 0
    skipped: int = 0
    seconds: float = 0.0
    failed: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when every planned run has a complete store."""
        return all(r["status"] == "complete" for r in self.records)

    @property
    def validation_failed(self) -> list[str]:
        """Names of the runs whose field failed validation (only when the sweep validates)."""
        return [r["name"] for r in self.records if r.get("validation") and not r["validation"].get("passed")]

    @property
    def lidar_failed(self) -> list[str]:
        """Names of the runs whose virtual-lidar coherence departed from theory (only with a lidar)."""
        return [r["name"] for r in self.records if r.get("lidar") and not r["lidar"].get("passed")]


def summary_table(result: SweepResult) -> str:
    """Plain-text table of every run, then the totals, failed validations, the lidar numbers (mean +- sd of
    k_0.5 [rad/m] and cut-off [Hz], with theory) and failed lidar checks."""
    rows = [("run", "status", "action", "seconds", "sigma_u", "validation", "error")]
    for r in result.records:
        sig = r.get("sigma_m_s") or [None]
        val = r.get("validation")
        rows.append((r["name"], r["status"], r["action"],
                     "" if r.get("duration_s") is None else f"{r['duration_s']:.1f}",
                     "" if sig[0] is None else f"{sig[0]:.3f}",
                     "" if val is None else ("pass" if val.get("passed") else "FAIL"), (r.get("error") or "")[:70]))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    n_ok = sum(r["status"] == "complete" for r in result.records)
    lines.append(
        f"{n_ok}/{len(result.records)} complete ({result.ran} generated, {result.skipped} already there), "
        f"{len(result.failed)} failed or pending, {result.seconds:.1f} s -> {result.out}"
    )
    if result.validation_failed:
        lines.append(f"validation failed for {len(result.validation_failed)}: {', '.join(result.validation_failed)}")
    lidar = [r["lidar"] for r in result.records if r.get("lidar") and "simulated" in r["lidar"]]
    if lidar:
        k05 = np.array([d["simulated"].get("k05_rad_m") or np.nan for d in lidar], dtype=float)
        fc = np.array([d["simulated"].get("cutoff_hz") or np.nan for d in lidar], dtype=float)
        th = lidar[0]["theory"]
        lines.append(f"lidar over {len(lidar)} fields: k_0.5 {np.nanmean(k05):.4f} +- {np.nanstd(k05):.4f} rad/m "
                     f"(theory {th.get('k05_rad_m') or float('nan'):.4f}), cut-off {np.nanmean(fc):.4f} +- "
                     f"{np.nanstd(fc):.4f} Hz (theory {th.get('cutoff_hz') or float('nan'):.4f})")
    if result.lidar_failed:
        lines.append(f"lidar coherence failed for {len(result.lidar_failed)}: {', '.join(result.lidar_failed)}")
    return "\n".join(lines)
