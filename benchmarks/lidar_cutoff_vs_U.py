"""Cut-off frequency of |G_RL| against mean wind speed (Guo et al. 2023 Fig. 5) for the Table 3 lidar.

Writes docs/lidar_cutoff_vs_U.png and prints the table (Hz) with the time it took.
Usage: python benchmarks/lidar_cutoff_vs_U.py [--speeds 12,14,...,24]
"""

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from turbgen.virtual_lidar.description import PRESETS
from turbgen.virtual_lidar.preview import preview_spectra
from turbgen.theory.lidar_control import cutoff_frequency_hz

PAPER_16 = {("mann", "unstable"): 0.0544, ("mann", "neutral"): 0.0490, ("mann", "stable"): 0.0455,
            ("kaimal", "unstable"): 0.0347, ("kaimal", "neutral"): 0.0449, ("kaimal", "stable"): 0.0439}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--speeds", default="12,14,16,18,20,22,24")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "lidar_cutoff_vs_U.png"))
    a = ap.parse_args()
    speeds = [float(s) for s in a.speeds.split(",")]
    lidar = PRESETS["nacelle-4beam"]
    table = {}
    t0 = time.time()
    for model in ("mann", "kaimal"):
        for preset in ("unstable", "neutral", "stable"):
            for U in speeds:
                f = np.geomspace(0.02, 0.1, 12) * U / 16.0  # the cut-off scales about with U
                S = preview_spectra(model, lidar, U, preset=preset, f_hz=f)
                table[(model, preset, U)] = cutoff_frequency_hz(f, S.G_RL)
    print(f"computed in {time.time() - t0:.0f} s")
    print("| model | class | " + " | ".join(f"{U:g} m/s" for U in speeds) + " | paper at 16 m/s |")
    print("|---|---|" + "---|" * (len(speeds) + 1))
    for model in ("mann", "kaimal"):
        for preset in ("unstable", "neutral", "stable"):
            row = " | ".join(f"{table[(model, preset, U)]:.4f}" for U in speeds)
            print(f"| {model} | {preset} | {row} | {PAPER_16[(model, preset)]:.4f} |")
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for model, ls in (("mann", "-"), ("kaimal", "--")):
        for preset, c in (("unstable", "C3"), ("neutral", "C0"), ("stable", "C2")):
            ax.plot(speeds, [table[(model, preset, U)] for U in speeds], ls, color=c, marker="o", ms=3,
                    label=f"{model} {preset}")
            ax.plot([16.0], [PAPER_16[(model, preset)]], "x", color=c, ms=7)
    ax.set(xlabel="mean wind speed U [m/s]", ylabel="-3 dB cut-off of |G_RL| [Hz]",
           title="Table 3 lidar, NREL 5 MW (x: Guo et al. 2023 Table 5)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(a.out, dpi=110)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
