"""The lidar loop (issue 26): a Mann field conditioned on the virtual lidar's measurements of another one.

    python benchmarks/lidar_loop.py                  # 1024 x 11 planes x 16 x 16, dy = dz = 8 m (docs/lidar_loop.png)
    python benchmarks/lidar_loop.py --nt 256 --quick # the size of tests/constrain/test_lidar_loop.py, no figure

truth = the Mann space-time field of seed 1 (default parameters: L 49 m, Gamma 3.1, gamma 400 s, U 16 m/s, IEC A)
with the default gates 50 .. 169.7 m; its virtual-lidar output (`turbgen lidar --out`, the 4-beam pulsed lidar of
Guo et al. 2023, Table 3: 4 beams x 10 gates, 37 probe points) constrains seed 2: a conditional sample and the
conditional mean (Hoffman & Ribak 1991). For the rotor-effective wind u_RR (u averaged over the rotor disc at x = 0,
Guo et al. 2023 Eq. 23, on the lidar's arrival-time grid) and for a hub-height sonic (u at y = z = 0 of the rotor
plane), each field is compared with the truth's:

- magnitude-squared coherence with the truth's signal (Welch, the lidar report's segments), against the preview
  theory's gamma^2_RL of the truth's store (turbgen.virtual_lidar.report.store_theory: u_LL vs u_RR of what the box holds).
  The conditional mean mu = E[T | d] has cov(mu, T) = var(mu), so its coherence with T is the fraction of T's
  spectrum explained by *all* the data: >= gamma^2_RL, which u_LL (one linear function of the data) explains.
  A conditional sample mu + r, r independent of T with the posterior variance, has coherence (gamma^2_mu)^2.
- RMSE against the truth: E|mu - T|^2 = posterior variance P, E|sample - T|^2 = 2 P, E|seed 2 - T|^2 = 2 var(T).

The constrained sample is validated (`turbgen validate`: the data come from the same model, so it is marginally a
prior sample). Timings and results go to stdout; the figure to docs/lidar_loop.png.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

import turbgen
from turbgen.virtual_lidar import signals
from turbgen.store import open_store


def hub_sonic(fs, t_s: np.ndarray) -> np.ndarray:
    """u [m/s] at y = z = 0 of the rotor plane (bilinear in y, z, linear in t) at the stored times ``t_s``."""
    g = fs.grid
    u = fs.read_plane("u", int(np.argmin(np.abs(g.x())))).astype(float)
    fy, fz = (0.0 - g.y()[0]) / g.dy_m, (0.0 - g.z()[0]) / g.dz_m
    iy, iz = int(fy), int(fz)
    ay, az = fy - iy, fz - iz
    at = ((1 - ay) * (1 - az) * u[:, iy, iz] + ay * (1 - az) * u[:, iy + 1, iz] + (1 - ay) * az * u[:, iy, iz + 1]
          + ay * az * u[:, iy + 1, iz + 1])  # fmt: skip
    return np.interp(t_s, g.t(), at)


def make_fields(work: Path, nt: int, ny: int, dy: float, threads: int | None) -> dict:
    """truth (seed 1), its lidar dataset, seed 2 plain, conditioned (sample) and the conditional mean; seconds."""
    # the IEC class A level of the defaults given explicitly: the prior's ae is the truth's (none given, a
    # constrained run would estimate it from the data)
    common = dict(nt=nt, ny=ny, nz=ny, dy=dy, gates="50:170:13.3", config={"turb_class": "A"}, threads=threads)
    seconds = {}

    def timed(name, fn):
        t0 = time.perf_counter()
        out = fn()
        seconds[name] = time.perf_counter() - t0
        return out

    timed("truth", lambda: turbgen.mann(seed=1, out=work / "truth.zarr", **common))
    report = timed("lidar", lambda: turbgen.lidar(work / "truth.zarr", out=work / "truth_lidar.zarr"))
    timed("seed 2", lambda: turbgen.mann(seed=2, out=work / "seed2.zarr", **common))
    lidar_data = [work / "truth_lidar.zarr"]
    timed("sample", lambda: turbgen.mann(seed=2, out=work / "sample.zarr", constrain=lidar_data, **common))
    timed("mean", lambda: turbgen.mann(seed=2, out=work / "mean.zarr", constrain=lidar_data, conditional_mean=True,
                                       **common))  # fmt: skip
    return {"report": report, "seconds": seconds}


def loop_statistics(work: Path, report) -> dict:
    """Coherence with the truth (per Welch bin of the lidar report) and RMSE of u_RR and the hub sonic for seed 2,
    the sample and the mean; the theory's gamma^2_RL at those bins."""
    run = report.run
    t, radius, setup = run.t_arrival_s, run.rotor_radius_m, run.welch["setup"]
    nbin = len(report.f_hz)
    signal = {}
    for name in ("truth", "seed2", "sample", "mean"):
        fs = open_store(work / f"{name}.zarr")
        signal[name] = {"u_RR": signals.rotor_average(fs, radius, t)[0], "sonic": hub_sonic(fs, t)}
    out = {"f_hz": report.f_hz, "coh2_RL_theory": report.coh2_theory, "rotor_radius_m": radius,
           "n_segments": run.welch["n_segments"], "n_eff": run.welch["n_eff"]}  # fmt: skip
    for quantity in ("u_RR", "sonic"):
        truth = signal["truth"][quantity]
        for name in ("seed2", "sample", "mean"):
            x = signal[name][quantity]
            w = signals.welch_rl(x, truth, setup)
            out[f"{quantity}/{name}/coh2"] = w["coh2_RL"][1 : 1 + nbin]
            out[f"{quantity}/{name}/rmse_m_s"] = float(np.sqrt(np.mean((x - truth) ** 2)))
        out[f"{quantity}/truth/std_m_s"] = float(truth.std())
    return out


BAND_COH2 = 0.1  # the band of the table: the Welch bins where the theory's gamma^2_RL >= this


def table(stats: dict) -> str:
    """The results as a markdown table: coherence with the truth averaged over the bins where the theory's
    gamma^2_RL >= BAND_COH2 (the lidar's band), and the RMSEs over the record."""
    f, th = stats["f_hz"], stats["coh2_RL_theory"]
    band = th >= BAND_COH2
    rows = [f"band: the {band.sum()} Welch bins {f[band].min():.4f} .. {f[band].max():.4f} Hz where the theory's "
            f"gamma^2_RL >= {BAND_COH2}; their mean gamma^2_RL = {th[band].mean():.3f}", "",
            "| signal | field | coherence with truth (band mean) | RMSE [m/s] | RMSE / seed-2 RMSE |",
            "|---|---|---|---|---|"]  # fmt: skip
    for q in ("u_RR", "sonic"):
        base = stats[f"{q}/seed2/rmse_m_s"]
        for name in ("seed2", "sample", "mean"):
            c = float(stats[f"{q}/{name}/coh2"][band].mean())
            r = stats[f"{q}/{name}/rmse_m_s"]
            rows.append(f"| {q} | {name} | {c:.3f} | {r:.3f} | {r / base:.2f} |")
        mean_c = stats[f"{q}/mean/coh2"][band]
        rows.append(f"| {q} | (mean's coherence)^2, expected for a sample | {float((mean_c**2).mean()):.3f} | "
                    f"sqrt(2) x mean's: {np.sqrt(2) * stats[f'{q}/mean/rmse_m_s']:.3f} | |")
    return "\n".join(rows)


def figure(stats: dict, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    f = stats["f_hz"]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, q in zip(axes, ("u_RR", "sonic")):
        mean = stats[f"{q}/mean/coh2"]
        ax.semilogx(f, mean, "C0-", label="conditional mean vs truth")
        ax.semilogx(f, stats[f"{q}/sample/coh2"], "C1-", label="conditional sample vs truth")
        ax.semilogx(f, mean**2, "C1:", label="(mean's coherence)$^2$: expected for a sample")
        ax.semilogx(f, stats[f"{q}/seed2/coh2"], "0.6", lw=0.8, label="unconstrained seed 2 vs truth")
        if q == "u_RR":
            ax.semilogx(f, stats["coh2_RL_theory"], "k--", label=r"preview theory $\gamma^2_{RL}$ (u$_{LL}$)")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("f [Hz]")
        ax.set_title(f"{'rotor-effective wind u_RR' if q == 'u_RR' else 'hub-height sonic u'}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("magnitude-squared coherence with the truth [-]")
    axes[0].legend(fontsize=8, loc="lower left")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nt", type=int, default=1024)
    ap.add_argument("--ny", type=int, default=16, help="ny = nz")
    ap.add_argument("--dy", type=float, default=8.0, help="dy = dz [m]")
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--quick", action="store_true", help="no figure")
    ap.add_argument("--work", help="keep the stores here (default: a temporary directory)")
    ap.add_argument("--reuse", action="store_true", help="use the stores already in --work (same size options)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="lidar-loop-") as tmp:
        work = Path(a.work or tmp)
        work.mkdir(parents=True, exist_ok=True)
        if a.reuse:  # the stores of an earlier run in --work: only the statistics, table and figure
            made = {"report": turbgen.lidar(work / "truth.zarr"), "seconds": {}}
        else:
            made = make_fields(work, a.nt, a.ny, a.dy, a.threads)
        stats = loop_statistics(work, made["report"])
        t0 = time.perf_counter()
        rep = turbgen.validate(work / "sample.zarr")
        made["seconds"]["validate sample"] = time.perf_counter() - t0
        size = f"{a.nt} x 11 planes x {a.ny} x {a.ny}, dy = dz = {a.dy:g} m"
        print(f"lidar loop on {size}; rotor radius {stats['rotor_radius_m']:g} m; "
              f"{stats['n_segments']} Welch segments")
        print(json.dumps({k: round(v, 1) for k, v in made["seconds"].items()}))
        print(table(stats))
        print(f"turbgen validate of the conditional sample: {'passed' if rep.passed else 'FAILED ' + str(rep.failed)}")
        if not a.quick:
            out = Path(__file__).parents[1] / "docs" / "lidar_loop.png"
            figure(stats, out, f"Mann seed 2 conditioned on the Table 3 lidar's measurements of seed 1 ({size})")
            print(f"wrote {out}")


if __name__ == "__main__":
    main()
