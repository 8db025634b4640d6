"""Coverage of the 95 % interval of the eddy-evolution time gamma fitted by `turbgen fit mann` to two planes along x.

For every realisation (seed) of a Mann space-time field with known (ae, L, Gamma, gamma) on two planes dx apart (in
memory, the grid model) the fit (``turbgen.fit_mann``: ae, L, Gamma from the one-point spectra, then gamma from the
co-coherence of u between the planes' 8 x 8 sub-lattices, or between two masts of 4 sensors cut from the planes,
cases 2-3: ``points``, the grid model, as bench_fit.py's mast4; cases 4-5: the same masts' series drawn from the
continuous model, ``mast_series``, fitted as a sensor file) and, to tell the interval's own calibration from the
uncertainty that L and Gamma carry into it, gamma alone with ae, L, Gamma held at their true values ("oracle").
Coverage: the fraction of realisations whose interval holds the true gamma; its binomial standard error is
sqrt(p (1 - p) / n).

    python benchmarks/bench_fit_evo.py --n 50 --out benchmarks/fit_evo_results.jsonl [--case 0 --seed0 2000]
    python benchmarks/bench_fit_evo.py --summary benchmarks/fit_evo_results.jsonl

The summary's second table: bias of ln gamma-hat, the scatter of (ln gamma-hat - ln gamma) / the fit's sd (1 when
calibrated), CPU s per fit (ae, L, Gamma and gamma) and how often the frozen (Taylor) limit is excluded.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import pickle
import time

import numpy as np

import turbgen
from turbgen.spec.constraints import PointSensor, PointSeries
from turbgen.theory.eddy_lifetime import evolution_lifetime_s
from turbgen.theory.mann_quadrature import perpendicular_quadrature
from turbgen.theory.mann_spectra import one_point_spectra
from turbgen.theory.params import MannParams
from turbgen.validation.fit import load_fit_data
from turbgen.validation.fit.evolution import N_NODES, Z95, fit_evolution, with_evolution
from turbgen.validation.fit.mann import fit_mann_data
from turbgen.validation.fit.model import PAIRS

CASES = [  # (ae, L, Gamma, gamma [s], dx [m])
    (0.08, 30.0, 3.2, 100.0, 100.0),
    (0.08, 30.0, 3.2, 400.0, 60.0),
    (0.08, 30.0, 3.2, 100.0, 200.0),
    (0.08, 30.0, 3.2, 400.0, 50.0),
]
MAST = [(3.0, z) for z in (-33.0, -9.0, 9.0, 33.0)]  # (y, z) [m] of a mast's 4 sensors (bench_fit.py's mast4)
# per case: the planes' 8 x 8 sub-lattices (None), two masts cut from the field (MAST), or two masts' series drawn
# from the continuous model ("series", ``mast_series``)
POINTS = [None, None, MAST, MAST, "series", "series", "series", "series"]
CASES += CASES[2:4] + [CASES[0], CASES[3]]
# the second mast's offset across the wind [m] (cases 6-7: the masts' line 10 deg off the wind, d = dx / cos 10 deg)
LATERAL_M = [0.0] * 6 + [CASES[0][4] * math.tan(math.radians(10.0)), CASES[3][4] * math.tan(math.radians(10.0))]
GRID = dict(nt=1024, ny=12, nz=12, dy=6.0, dz=6.0, U=10.0, dt=0.5)


def _data(case: int, seed: int, cache: str | None):
    """FitData of one realisation, from ``cache`` (a pickle per case and seed) when there."""
    ae, L, G, evo, dx = CASES[case]
    path = cache and os.path.join(cache, f"case{case}_seed{seed}.pkl")
    if path and os.path.exists(path):
        with open(path, "rb") as fh:
            return pickle.load(fh)
    if POINTS[case] == "series":
        fd = load_fit_data(mast_series(case, seed), GRID["U"])
    else:
        fd = load_fit_data(turbgen.mann(L=L, gamma=G, ae=ae, evo=evo, planes=[0, dx], seed=seed, **GRID), None,
                           POINTS[case])
    if path:
        os.makedirs(cache, exist_ok=True)
        with open(path + ".tmp", "wb") as fh:
            pickle.dump(fd, fh)
        os.replace(path + ".tmp", path)
    return fd


@functools.lru_cache(maxsize=2)
def _mast_factor(case: int) -> np.ndarray:
    """(nt / 2 - 1, 24, 24) Cholesky factors of the lines' covariance E c_a,p conj c_b,q [m^2 s^-2] of u, v, w at the
    two masts' 8 sensors in the convected frame: the continuous model's cross-spectra (Guo et al. 2023, Eq. 8) with
    the decay exp(-|dx| / (U tau_e(|k|))) inside the (k2, k3) integral (Eq. 13, 15), separations r_a - r_b as in
    ``covariance.separations``; coherencies at N_NODES k1 nodes, interpolated in ln k1 to the lines and scaled by
    the one-point spectra there."""
    ae, L, G, evo, dx = CASES[case]
    params, n, U = MannParams(ae, L, G, evo_time_s=evo), GRID["nt"], GRID["U"]
    dk = 2 * np.pi / (n * U * GRID["dt"])
    k1 = dk * np.arange(1, n // 2)
    nodes = np.geomspace(k1[0], k1[-1], N_NODES)
    sites = [(x, y + (LATERAL_M[case] if x else 0.0), z) for x in (0.0, dx) for y, z in MAST]
    cov = np.zeros((k1.size, 3 * len(sites), 3 * len(sites)), complex)
    cross: dict = {}
    one = one_point_spectra(k1, params)
    sd = np.sqrt(np.stack([one[f] for f in ("F11", "F22", "F33")], axis=1) * dk)  # (lines, 3)
    for a, (xa, ya, za) in enumerate(sites):
        for b, (xb, yb, zb) in enumerate(sites):
            key = (ya - yb, za - zb, abs(xa - xb))
            if key not in cross:
                kappa, w, g = perpendicular_quadrature(nodes, params, PAIRS, key[0], key[1])
                w = w * np.exp(-key[2] / (U * evolution_lifetime_s(np.hypot(nodes[:, None], kappa), params)))
                cross[key] = {pq: (w * g[pq]).sum(axis=-1) for pq in PAIRS}
            for p, q in PAIRS:
                c = cross[key][(p, q)] / np.sqrt(cross[(0.0, 0.0, 0.0)][(p, p)] * cross[(0.0, 0.0, 0.0)][(q, q)])
                c = np.interp(np.log(k1), np.log(nodes), c.real) + 1j * np.interp(np.log(k1), np.log(nodes), c.imag)
                cov[:, 3 * a + p, 3 * b + q] = cov[:, 3 * a + q, 3 * b + p] = c * sd[:, p] * sd[:, q]
    return np.linalg.cholesky(cov)


def mast_series(case: int, seed: int) -> PointSeries:
    """Fluctuations of u, v, w at two masts dx apart (4 sensors each, MAST), Gaussian and periodic with the
    continuous model's lines (``_mast_factor``; a sensor holds every wavenumber, unlike a point of a grid); the
    downstream mast's series delayed by dx / U (Taylor), whole samples when dx / (U dt) is an integer; the sensors of
    the factor's second mast (labelled x = 0) LATERAL_M[case] across the wind from the first."""
    n, dx = GRID["nt"], CASES[case][4]
    chol = _mast_factor(case)
    rng = np.random.default_rng(seed)
    z = (rng.standard_normal(chol.shape[:2]) + 1j * rng.standard_normal(chol.shape[:2])) / np.sqrt(2)
    X = np.zeros((n // 2 + 1, chol.shape[1]), complex)
    X[1: n // 2] = n * np.einsum("mij,mj->mi", chol, z)
    u = np.fft.irfft(X, n, axis=0).reshape(n, -1, 3)
    lag = round(dx / (GRID["U"] * GRID["dt"]))
    sensors = tuple(PointSensor(f"s{a}", dx * (a < len(MAST)), y + LATERAL_M[case] * (a >= len(MAST)), zz, None,
                                {c: np.roll(u[:, a, k], 0 if a < len(MAST) else lag) for k, c in enumerate("uvw")})
                    for a, (y, zz) in enumerate(MAST * 2))
    return PointSeries("masts", GRID["dt"] * np.arange(n), sensors, False, None, "bench_fit_evo masts")


def one(case: int, seed: int, cache: str | None = None) -> dict:
    ae, L, G, evo, dx = CASES[case]
    t0 = time.perf_counter()
    fd = _data(case, seed, cache)
    t1, c1 = time.perf_counter(), time.process_time()
    fit = with_evolution(fd, fit_mann_data(fd))
    t2, c2 = time.perf_counter(), time.process_time()
    oracle = fit_evolution(fd, MannParams(ae, L, G), fit.nperseg)
    e = fit.evolution
    pair = next(iter(e.data))  # the pair of positions (x, y)
    return {"case": case, "seed": seed, "truth": evo, "dx_m": dx, "value": e.value_s, "ci95": list(e.ci95),
            "ci95_held": list(e.ci95_held), "sensitivity": list(e.sensitivity), "oracle_value": oracle.value_s,
            "oracle_ci95": list(oracle.ci95), "ae": fit.ae.value, "L": fit.length_scale_m.value,
            "Gamma": fit.gamma.value, "cov_fit": fit.cov_fit.tolist(), "gain": fit.gain.tolist(),
            "sd_1pt": {k: list(v) for k, v in fit.sd.items()}, "f_hz_1pt": list(fit.f_hz), "chi2_dof_1pt": fit.chi2_dof,
            "lateral_m": list(e.lateral_m), "chi2": e.chi2, "dof": e.dof, "chi2_frozen": e.chi2_frozen, "f_hz": list(e.f_hz),
            "r": list(e.data[pair]), "r_sd": list(e.sd[pair]), "oracle_r_fitted": list(oracle.fitted[pair]),
            "t_gen_s": t1 - t0, "t_fit_s": t2 - t1, "cpu_fit_s": c2 - c1,
            "identified": e.identified}


def inside(ci, truth) -> bool:
    return ci[0] <= truth and (ci[1] is None or truth <= ci[1])


def intervals(r: dict) -> dict:
    """The realisation's 95 % intervals of gamma by construction: "held" (coherence alone, L and Gamma at their
    fit), "quadrature" (+ the shifts of L and Gamma as if independent: the old one), "joint" (+ s^T Sigma s), "fit"
    (the product's: + the cross term with the coherence), "oracle" (ae, L, Gamma at the truth)."""
    out = {"fit": r["ci95"], "oracle": r["oracle_ci95"], "held": r["ci95_held"]}
    if None in r["ci95_held"] or r["ci95_held"][0] is None:
        return out | {"quadrature": r["ci95_held"], "joint": r["ci95_held"]}
    x, s, cov = math.log(r["value"]), np.array(r["sensitivity"]), np.array(r["cov_fit"])
    quad, joint = float(np.sum((s * np.sqrt(np.diag(cov))) ** 2)), float(s @ cov @ s)
    for name, var in (("quadrature", quad), ("joint", joint)):
        out[name] = [math.exp(x + side * math.hypot(math.log(e) - x, Z95 * math.sqrt(var)))
                     for e, side in zip(r["ci95_held"], (-1, 1))]
    return out


KINDS = ("held", "quadrature", "joint", "fit", "oracle")


def summary(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    print("| case (ae, L, Γ, γ, dx) | sensors | n | " + " | ".join(f"{k} (± se)" for k in KINDS) + " | median γ̂ / γ "
          "| sd ln γ̂ | rms sd fit | corr(ln γ̂_oracle, ln L̂) |")
    print("|---" * (len(KINDS) + 7) + "|")
    second = []
    for c, spec in enumerate(CASES):
        rs = [r for r in rows if r["case"] == c]
        if not rs:
            continue
        n = len(rs)
        cells = []
        for kind in KINDS:
            p = np.mean([inside(intervals(r)[kind], r["truth"]) for r in rs])
            cells.append(f"{100 * p:.0f} % ± {100 * math.sqrt(p * (1 - p) / n):.0f}")
        lg = np.log([r["value"] / r["truth"] for r in rs])
        sd_fit = np.array([(math.log(r["ci95"][1]) - math.log(r["ci95"][0])) / (2 * Z95) if r["ci95"][1] else np.nan
                           for r in rs])
        corr = np.corrcoef(np.log([r["oracle_value"] for r in rs]), np.log([r["L"] for r in rs]))[0, 1]
        where = "planes 8 × 8" if POINTS[c] is None else "series 4 + 4" if POINTS[c] == "series" else "masts 4 + 4"
        where += f", {LATERAL_M[c]:.3g} m across" if LATERAL_M[c] else ""
        print(f"| {spec} | {where} | {n} | {' | '.join(cells)} | {np.exp(np.median(lg)):.3f} | {lg.std(ddof=1):.3f} "
              f"| {math.sqrt(np.nanmean(np.square(sd_fit))):.3f} | {corr:.2f} |")
        second.append(_details(spec, rs, lg, sd_fit))
    print("\n| case | bias ln γ̂ (± se) | scatter (ln γ̂ − ln γ) / sd fit | truth below / above interval | CPU s per fit "
          "(median) | Taylor (γ → ∞) excluded | median χ² at γ̂ / frozen (dof) |\n|---|---|---|---|---|---|---|")
    print("\n".join(second))


def _details(spec, rs: list, lg: np.ndarray, sd_fit: np.ndarray) -> str:
    """One row of the second table: bias, scatter ratio, misses by side, CPU per fit, the frozen limit's report."""
    ok = np.isfinite(sd_fit)
    below = sum(r["ci95"][0] > r["truth"] for r in rs)
    above = sum(r["ci95"][1] is not None and r["ci95"][1] < r["truth"] for r in rs)
    cpu = [r["cpu_fit_s"] for r in rs if "cpu_fit_s" in r]
    excluded = sum(r["ci95"][1] is not None for r in rs)
    chi = np.median([r["chi2"] for r in rs]), np.median([r["chi2_frozen"] for r in rs])
    return (f"| {spec} | {lg.mean():+.3f} ± {lg.std(ddof=1) / math.sqrt(len(lg)):.3f} | "
            f"{np.std(lg[ok] / sd_fit[ok], ddof=1):.2f} | {below} / {above} | "
            f"{f'{np.median(cpu):.1f}' if cpu else '–'} | {excluded} / {len(rs)} | {chi[0]:.1f} / {chi[1]:.0f} "
            f"({rs[0]['dof']}) |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=50, help="realisations")
    ap.add_argument("--case", type=int, default=0)
    ap.add_argument("--seed0", type=int, default=2000)
    ap.add_argument("--out", default="benchmarks/fit_evo_results.jsonl")
    ap.add_argument("--summary", default=None, help="print the coverage table of this results file and stop")
    ap.add_argument("--cases", default=None, help="comma-separated cases, interleaved (overrides --case)")
    ap.add_argument("--cache", default=None, help="directory of cached fields (pickled FitData)")
    a = ap.parse_args()
    if a.summary:
        summary(a.summary)
        return
    cases = [int(c) for c in a.cases.split(",")] if a.cases else [a.case]
    done = set()
    if os.path.exists(a.out):  # resumable: skip the realisations already in the results file
        done = {(r["case"], r["seed"]) for r in map(json.loads, open(a.out))}
    with open(a.out, "a") as fh:
        for seed in range(a.seed0, a.seed0 + a.n):
            for case in (c for c in cases if (c, seed) not in done):
                fh.write(json.dumps(one(case, seed, a.cache)) + "\n")
                fh.flush()


if __name__ == "__main__":
    main()
