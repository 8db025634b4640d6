"""`turbgen fit mann` beside wetb's `fit_mann_model_spectra` on turbgen fields with known (ae, L, Gamma).

Per realisation (frozen Mann field, one plane, 8192 x 16 x 16 points, dx = U dt = 6 m, dy = dz = 6 m):
  box     turbgen: the field against the Mann tensor summed over its generator's box (grid-aware);
          wetb: `fit_mann_model_spectra(*spectra(1 / dx, u, v, w))` over the 256 columns (the continuous model);
  sonic   one sensor's u, v, w series (``--nt`` samples at ``--dt``, default 8192 at 0.5 s; a 10-minute 20 Hz sonic:
          --nt 12000 --dt 0.05) drawn from the continuous model's one-point spectra F11, F22, F33 and co-spectrum
          F13 (Mann 1994) at the record's own wavenumbers (a sensor whose spectra hold every wavenumber, unlike a
          point of a box): turbgen against the continuous model, wetb as above; reported is whether wetb's values
          lie inside turbgen's 95 % intervals, and wetb's fit of the noise-free model spectra at the same lines
          (its bias without any sampling error).
``--lifetime mann`` makes the fields and the sensor series with Mann's (1994) eddy lifetime, the one of wetb's table,
and fits turbgen with it (the fair comparison); the default is the generator's (Guo et al. 2023).
wetb (the DTU Wind Energy Toolbox, PyPI `wetb`) is a benchmark peer only: `pip install --no-deps wetb` suffices
for its mann_parameters module (numpy, scipy).

    python benchmarks/bench_fit_wetb.py --n 10 --out /tmp/fit_wetb.jsonl
    python benchmarks/bench_fit_wetb.py --kinds sonic --nt 12000 --dt 0.05 --n 25 --out /tmp/fit_wetb.jsonl
    python benchmarks/bench_fit_wetb.py --lifetime mann --n 25 --out /tmp/fit_wetb_mann.jsonl
    python benchmarks/bench_fit_wetb.py --summary /tmp/fit_wetb.jsonl
"""

from __future__ import annotations

import argparse
import functools
import json
import time

import numpy as np

import turbgen
from turbgen.spec.constraints import PointSensor, PointSeries
from turbgen.theory.mann_spectra import one_point_spectra
from turbgen.theory.params import MannParams

CASES = [(0.08, 30.0, 3.2), (0.05, 60.0, 2.0)]  # (ae, L, Gamma) of the fields
U_M_S, DT_S, DY_M = 12.0, 0.5, 6.0
NAMES = ("ae", "length_scale_m", "gamma")


def wetb_fit(dx_m: float, u, v, w) -> tuple[list[float], float]:
    from wetb.wind.turbulence.mann_parameters import fit_mann_model_spectra
    from wetb.wind.turbulence.spectra import spectra

    t0 = time.process_time()
    ae, L, G = fit_mann_model_spectra(*spectra(1.0 / dx_m, u, v, w))
    return [float(ae), float(L), float(G)], time.process_time() - t0


def turbgen_fit(data, **kw) -> tuple[dict, float]:
    t0 = time.process_time()
    fit = turbgen.fit_mann(data, **kw)
    return {n: {"value": getattr(fit, n).value, "ci95": list(getattr(fit, n).ci95)} for n in NAMES}, \
        time.process_time() - t0


@functools.lru_cache(maxsize=4)
def _line_spectra(case: tuple, n: int, dt_s: float, lifetime: str = "guo") -> tuple[float, dict]:
    """(dk [rad/m], the one-point spectra at the n-sample record's lines k_m = m dk, 0 < m < n / 2)."""
    dk = 2 * np.pi / (n * U_M_S * dt_s)
    return dk, one_point_spectra(dk * np.arange(1, n // 2), MannParams(*case, lifetime))


def wetb_noise_free(case, n: int, dt_s: float, lifetime: str = "guo") -> list[float]:
    """wetb's (ae, L, Gamma) fitted to the model's expected spectra at the record's lines (no sampling error)."""
    from wetb.wind.turbulence.mann_parameters import fit_mann_model_spectra

    dk, F = _line_spectra(tuple(case), n, dt_s, lifetime)
    spectra = (F[k] for k in ("F11", "F22", "F33", "F13"))
    return [float(x) for x in fit_mann_model_spectra(dk * np.arange(1, n // 2), *spectra)]


def sonic_series(case, seed: int, n: int = 8192, dt_s: float = DT_S, lifetime: str = "guo") -> dict:
    """u, v, w (n,) [m/s] of one point, periodic, Gaussian with the continuous model's one-point spectra at the
    record's wavenumbers k_m = 2 pi m / (n dx): E|c_m|^2 = F(k_m) dk per line (two-sided F; the Nyquist line 0)."""
    dk, F = _line_spectra(tuple(case), n, dt_s, lifetime)
    rng = np.random.default_rng(seed)
    z = (rng.standard_normal((3, n // 2 - 1)) + 1j * rng.standard_normal((3, n // 2 - 1))) / np.sqrt(2)
    a = np.sqrt(F["F11"] * dk)  # u, w jointly: the Cholesky factor of dk [[F11, F13], [F13, F33]]
    b = F["F13"] * dk / a
    c_m = {"u": a * z[0], "v": np.sqrt(F["F22"] * dk) * z[1], "w": b * z[0] + np.sqrt(F["F33"] * dk - b * b) * z[2]}
    out = {}
    for name, c in c_m.items():
        X = np.zeros(n // 2 + 1, complex)
        X[1 : n // 2] = n * c
        out[name] = np.fft.irfft(X, n)
    return out


def realisation(case, seed: int, kinds=("box", "sonic"), nt: int = 8192, dt_s: float = DT_S,
                lifetime: str = "guo") -> list[dict]:
    ae, L, G = case
    todo = []
    if "box" in kinds:
        ds = turbgen.mann(L=L, gamma=G, ae=ae, seed=seed, nt=8192, dt=DT_S, ny=16, nz=16, dy=DY_M, dz=DY_M,
                          planes=[0], evo=None, U=U_M_S, lifetime=lifetime)
        todo.append(("box", ds, {}, {c: ds[c].values[:, 0].reshape(ds.sizes["t"], -1).astype(float) for c in "uvw"}))
    if "sonic" in kinds:
        series = sonic_series(case, seed, nt, dt_s, lifetime)
        sonic = PointSeries("sonic", dt_s * np.arange(nt), (PointSensor("s", 0.0, 0.0, 0.0, None, series),),
                            total_wind=False, noise_m_s=None, source="bench_fit_wetb sonic")
        todo.append(("sonic", sonic, {"U": U_M_S}, series))
    rows = []
    for kind, tg_data, kw, arrays in todo:
        tg, tg_cpu = turbgen_fit(tg_data, lifetime=lifetime, **kw)
        dt = dt_s if kind == "sonic" else DT_S
        wb, wb_cpu = wetb_fit(U_M_S * dt, arrays["u"], arrays["v"], arrays["w"])
        row = {"case": case, "seed": seed, "kind": kind, "turbgen": tg, "turbgen_cpu_s": tg_cpu,
               "wetb": dict(zip(NAMES, wb)), "wetb_cpu_s": wb_cpu, "lifetime": lifetime}
        if kind == "sonic":
            free = wetb_noise_free(case, nt, dt_s, lifetime)
            row |= {"nt": nt, "dt_s": dt_s, "wetb_noise_free": dict(zip(NAMES, free))}
        rows.append(row)
    return rows


def summary(path: str) -> None:
    """The table of a results file: per case, lifetime, data kind and record (nt, dt), both tools' error (mean ±
    sd over the realisations), wetb's inside turbgen's 95 % intervals, turbgen's own coverage (binomial se
    sqrt(0.95 0.05 / n)), wetb's error on the noise-free spectra, median CPU s."""
    rows = [json.loads(line) for line in open(path)]
    print("| (ae, L, Γ) | lifetime | data | record | n | turbgen error ae / L / Γ (mean ± sd) "
          "| wetb error ae / L / Γ (mean ± sd) "
          "| wetb inside turbgen's 95 % (ae / L / Γ) | turbgen's own coverage (ae / L / Γ) | wetb error, noise-free "
          "| CPU s per fit turbgen / wetb |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    records = sorted({(r.get("nt", 8192), r.get("dt_s", DT_S)) for r in rows})
    for case, lt, kind, (nt, dt) in [(c, lt, k, rec) for c in CASES for lt in ("guo", "mann") for k in ("box", "sonic")
                                     for rec in records]:
        sel = [r for r in rows if tuple(r["case"]) == case and r["kind"] == kind and r.get("lifetime", "guo") == lt
               and (r.get("nt", 8192), r.get("dt_s", DT_S)) == (nt, dt)]
        if not sel:
            continue

        def err(tool):
            e = np.array([[r[tool][n]["value"] if tool == "turbgen" else r[tool][n] for n in NAMES]
                          for r in sel]) / np.array(case) - 1
            return " / ".join(f"{100 * m:+.1f} ± {100 * s:.1f} %" for m, s in zip(e.mean(0), e.std(0, ddof=1)))

        def share(values):  # per parameter, the fraction of rows whose turbgen interval holds values(row)[k]
            hit = [[r["turbgen"][n]["ci95"][0] <= values(r)[k] <= r["turbgen"][n]["ci95"][1] for r in sel]
                   for k, n in enumerate(NAMES)]
            return " / ".join(f"{100 * np.mean(h):.0f} %" for h in hit)

        own = share(lambda r: case)
        inside = share(lambda r: [r["wetb"][n] for n in NAMES])
        free = " / ".join(f"{100 * (sel[0]['wetb_noise_free'][n] / c - 1):+.1f} %" for n, c in zip(NAMES, case)) \
            if "wetb_noise_free" in sel[0] else "-"
        cpu = f"{np.median([r['turbgen_cpu_s'] for r in sel]):.1f} / {np.median([r['wetb_cpu_s'] for r in sel]):.2f}"
        print(f"| {case} | {lt} | {kind} | {nt} × {dt} s | {len(sel)} | {err('turbgen')} | {err('wetb')} | {inside} | {own} "
              f"| {free} | {cpu} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=10, help="realisations per case")
    ap.add_argument("--seed0", type=int, default=2000)
    ap.add_argument("--out", default="fit_wetb.jsonl")
    ap.add_argument("--summary", help="print the table of a results file and stop")
    ap.add_argument("--kinds", default="box,sonic", help="comma-separated data kinds (box, sonic)")
    ap.add_argument("--nt", type=int, default=8192, help="samples of a sonic record")
    ap.add_argument("--dt", type=float, default=DT_S, help="sampling interval of a sonic record [s]")
    ap.add_argument("--lifetime", default="guo", choices=("guo", "mann"), help="eddy lifetime of data and fit")
    ap.add_argument("--cases", default="0,1", help="comma-separated indices into CASES (split runs)")
    a = ap.parse_args()
    if a.summary:
        summary(a.summary)
        return
    with open(a.out, "a") as fh:
        for seed in range(a.seed0, a.seed0 + a.n):
            for case in [CASES[int(i)] for i in a.cases.split(",")]:
                for row in realisation(case, seed, tuple(a.kinds.split(",")), a.nt, a.dt, a.lifetime):
                    fh.write(json.dumps(row) + "\n")
                    fh.flush()


if __name__ == "__main__":
    main()
