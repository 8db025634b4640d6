"""Time domain against frequency domain on default-size Mann 4D fields: the simulated lidar-rotor
coherence gamma^2_RL of the Table 3 lidar (Guo et al. 2023) over N seeds, against the space-time theory.

Each seed's default store (4096 x 11 planes x 64 x 64, 2.2 GB) is generated with the CLI, measured by
the virtual lidar, and deleted; the Welch spectra S_LL, S_RR, S_RL of all seeds are summed (their
degrees of freedom add up) before the coherence is formed. The same fields with the gates reading the
planes in reverse order (shuffled planes) must fail; with ``--frozen`` the same seeds generated with
``--evo frozen`` are compared against the *evolving* theory as well (they are too coherent; telling
them apart needs several hundred equivalent segments, i.e. most of the 10 default fields).

Writes benchmarks/lidar_time_vs_frequency.md and docs/lidar_time_vs_frequency.png.
Usage: python benchmarks/lidar_time_vs_frequency.py [--seeds 1-10] [--frozen] [--workdir DIR]
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from turbgen.virtual_lidar import compare, signals
from turbgen.virtual_lidar.description import load_lidar
from turbgen.virtual_lidar.report import store_theory
from turbgen.virtual_lidar.run import measurements_of
from turbgen.virtual_lidar.sampling import sample
from turbgen.store import open_store
from turbgen.validation.estimators import WelchSetup

ROOT = Path(__file__).resolve().parents[1]
NPERSEG = 256  # lidar steps of 0.25 s: 64 s segments, ~63 half-overlapping segments per 2048 s field


def _spectra(fs, desc, plane_map=None) -> dict:
    ms = measurements_of(desc)
    if plane_map is not None:
        ms = [replace(m, plane_x_m=plane_map[m.plane_x_m]) for m in ms]
    s = sample(fs, ms, *desc.schedule(fs.grid.nt * fs.grid.dt_s))
    t, u_ll = signals.lidar_estimate(s, fs.U_m_s)
    u_rr, _ = signals.rotor_average(fs, desc.rotor_radius_m, t)
    w = signals.welch_rl(u_ll, u_rr, WelchSetup(NPERSEG, float(t[1] - t[0])))
    return {**{k: w[k] for k in ("f_hz", "S_LL", "S_RR", "S_RL", "n_eff", "setup")}, "n_samples": t.size, "fields": 1}


def _add(acc: dict | None, w: dict) -> dict:
    if acc is None:
        return dict(w)
    return {**acc, **{k: acc[k] + w[k] for k in ("S_LL", "S_RR", "S_RL", "n_eff", "fields")}}


def _coh2(acc: dict) -> np.ndarray:
    return np.abs(acc["S_RL"]) ** 2 / (acc["S_LL"] * acc["S_RR"])


def _seeds(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", default="1-10")
    ap.add_argument("--frozen", action="store_true", help="also the same seeds with --evo frozen")
    ap.add_argument("--workdir", default=None, help="where the (deleted) stores are written")
    ap.add_argument("--report", default=str(ROOT / "benchmarks" / "lidar_time_vs_frequency.md"))
    ap.add_argument("--plot", default=str(ROOT / "docs" / "lidar_time_vs_frequency.png"))
    a = ap.parse_args()
    desc = load_lidar("nacelle-4beam")
    xs = sorted(desc.ranges_m)
    reverse = dict(zip(xs, xs[::-1]))
    work = Path(tempfile.mkdtemp(dir=a.workdir))
    acc = {"evolving": None, "shuffled": None, "frozen": None}
    theory = None
    t0 = time.time()
    kinds = ["evolving", *(["frozen"] if a.frozen else [])]
    try:
        for seed in _seeds(a.seeds):
            for kind in kinds:
                out = work / f"{kind}{seed}.zarr"
                extra = ["--evo", "frozen"] if kind == "frozen" else []
                subprocess.run([sys.executable, "-c", "from turbgen.cli import main; main()", "mann", "--seed", str(seed), *extra,
                                "--out", str(out)], check=True, capture_output=True)
                fs = open_store(out)
                acc[kind] = _add(acc[kind], _spectra(fs, desc))
                if kind == "evolving":
                    acc["shuffled"] = _add(acc["shuffled"], _spectra(fs, desc, reverse))
                    if theory is None:
                        f = acc["evolving"]["f_hz"]
                        th = store_theory(fs, desc, f[1:-1], desc.rotor_radius_m, acc["evolving"]["setup"],
                                          acc["evolving"]["n_samples"])
                        theory = np.concatenate([[0.0], th.coh2_RL, [0.0]])
                        segments = th.n_eff  # equivalent segments per field and bin (lowest bin: fewer)
                        U = fs.U_m_s
                del fs
                shutil.rmtree(out)
            print(f"seed {seed} done at {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    f = acc["evolving"]["f_hz"]
    rows, curves = [], {}
    for kind in ("evolving", "shuffled", "frozen"):
        if acc[kind] is None:
            continue
        c = _coh2(acc[kind])
        n_bins = np.concatenate([[acc[kind]["n_eff"]], acc[kind]["fields"] * segments, [acc[kind]["n_eff"]]])
        m = compare.coherence_metric(f, c, theory, n_bins)
        k05 = compare.preview_numbers(f, c, np.sqrt(np.clip(c, 0, 1)), U)["k05_rad_m"]
        rows.append((kind, acc[kind]["n_eff"], len(m.checks), m.max_abs_z, m.z_crit, m.passed, k05))
        curves[kind] = c
    k05_th = compare.preview_numbers(f[1:-1], theory[1:-1], np.sqrt(theory[1:-1]), U)["k05_rad_m"]
    n = len(_seeds(a.seeds))
    lines = [f"# Lidar-rotor coherence: {n} default Mann fields against the space-time theory", "",
             f"Run of {time.strftime('%Y-%m-%d')} (`python benchmarks/lidar_time_vs_frequency.py --seeds {a.seeds}"
             f"{' --frozen' if a.frozen else ''}`), {time.time() - t0:.0f} s. Table 3 four-beam lidar of Guo et al. "
             f"(2023), U = {U:g} m/s, default `turbgen mann` stores (neutral, gamma = 400 s); Welch segments of "
             f"{NPERSEG} lidar steps (64 s). Verdict: every coherence bin within the Bonferroni critical |z| "
             "(validator's design, false alarm 1e-3 per metric).", "",
             "| fields | equivalent segments | bins | max abs z | critical z | verdict | k_0.5 [rad/m] |",
             "|---|---|---|---|---|---|---|"]
    for kind, neff, nb, z, zc, ok, k05 in rows:
        lines.append(f"| {kind} | {neff:.0f} | {nb} | {z:.2f} | {zc:.2f} | {'PASS' if ok else 'FAIL'} | "
                     f"{k05 if k05 is None else f'{k05:.4f}'} |")
    lines += ["", f"Theory k_0.5 = {k05_th:.4f} rad/m.", ""]
    Path(a.report).write_text("\n".join(lines))
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(f[1:-1], theory[1:-1], "k-", lw=2, label="theory (space-time Mann)")
    for kind, c in curves.items():
        ax.plot(f[1:-1], c[1:-1], ".-", label=f"simulated, {kind} ({n} fields)")
    ax.set(xscale="log", xlabel="f [Hz]", ylabel="gamma^2_RL [-]", ylim=(0, 1.02),
           title="Lidar-rotor coherence: time domain vs theory")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(a.plot, dpi=110)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
