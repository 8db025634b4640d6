"""Issue 38's 10-minute ae interval, without fits: the band estimates' covariance against the fit's at the truth.

R records of one sensor (``bench_fit_wetb.sonic_series``, U = 12 m/s, --nt samples at --dt) of one parameter set:
the per-band variance of the band estimates over the fit's (``mann._covariance_at`` at the true parameters), the
correlation of neighbouring bands, and the linearised GLS estimate at the truth, A = (J'C^-1 J)^-1 J'C^-1 applied to
each record's band estimates: its sd over the records against sqrt(a'Ca) (standard error 1 / sqrt(2 R)). With
--results (a ``bench_fit.py`` jsonl) the same projection of those rows' seeds beside their fitted values.

    python benchmarks/bench_fit_sonic_cov.py --case 0.05,60,2 --n 2000 --seed0 100000
    python benchmarks/bench_fit_sonic_cov.py --case 0.05,60,2 --results benchmarks/fit_results_sonic_12000.jsonl
    python benchmarks/bench_fit_sonic_cov.py --kind mast4 --case 0.05,60,2 --n 500 --seed0 300000

--kind mast4: the 4-sensor mast of ``bench_fit.py``'s fields instead (grid model; --nt and --dt unused).
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
from bench_fit import POINTS, field
from bench_fit_wetb import U_M_S, sonic_series
from scipy.stats import chi2

from turbgen.spec.constraints import PointSensor, PointSeries
from turbgen.theory.params import MannParams
from turbgen.validation.fit.covariance import point_sets, separations
from turbgen.validation.fit.data import load_fit_data
from turbgen.validation.fit.mann import NAMES, _covariance_at
from turbgen.validation.fit.model import BandModel
from turbgen.validation.fit.spectra import SPECTRA, estimate_bands


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", default="0.05,60,2", help="ae,L,Gamma")
    ap.add_argument("--n", type=int, default=400)
    ap.add_argument("--seed0", type=int, default=100000)
    ap.add_argument("--nt", type=int, default=12000)
    ap.add_argument("--dt", type=float, default=0.05)
    ap.add_argument("--kind", default="sonic", choices=("sonic", "mast4"))
    ap.add_argument("--results", default=None, help="bench_fit.py rows: project their seeds of this case")
    a = ap.parse_args()
    case = tuple(float(v) for v in a.case.split(","))
    p = dict(zip(NAMES, case))

    def vector(seed):
        if a.kind == "mast4":
            data = load_fit_data(field(case, seed, None), None, POINTS["mast4"])
        else:
            s = PointSensor("s", 0.0, 0.0, 0.0, None, sonic_series(case, seed, a.nt, a.dt))
            data = load_fit_data(PointSeries("s", a.dt * np.arange(a.nt), (s,), False, None, "sonic"), U_M_S)
        b = estimate_bands(data)
        return data, b, np.stack([b.values[s] for s in SPECTRA], 1).ravel()

    data, bands, _ = vector(a.seed0)
    model = BandModel(bands, data.U_m_s, data.grid, data.box)
    model.update_ratio(MannParams(*case), slopes=True)  # the grid model's lattice ratio at the truth (mast4)
    cov = _covariance_at(bands, model, (*separations(data.sites_m), point_sets(data, SPECTRA)), SPECTRA, p)
    jac = []
    for n in NAMES:  # central differences in ln ae, ln L, Gamma
        e = [model.expected(**{**p, n: p[n] * math.exp(h) if n != "gamma" else p[n] + h}) for h in (1e-3, -1e-3)]
        jac.append(np.stack([(e[0][s] - e[1][s]) / 2e-3 for s in SPECTRA], 1).ravel())
    jac, ci = np.array(jac), np.linalg.inv(cov)
    gls = np.linalg.solve(jac @ ci @ jac.T, jac @ ci)
    sd = np.sqrt(np.einsum("pi,ij,pj->p", gls, cov, gls))
    print(f"{a.kind}, case {case}, nt {data.nt}, dt {bands.setup.dt_s} s, nperseg {bands.setup.nperseg}, segments "
          f"{bands.segments['u']}; GLS sd at the truth (ln ae, ln L, Gamma) {np.round(sd, 5)}")
    if a.results:
        rows = [r for r in map(json.loads, open(a.results)) if tuple(r["case"]) == case]
        x = np.array([vector(r["seed"])[2] for r in rows]) @ gls.T
        fit = np.array([[math.log(r["fit"][n]["value"] / t) if n != "gamma" else r["fit"][n]["value"] - t
                         for n, t in zip(NAMES, case)] for r in rows])
        print(f"{len(rows)} seeds of {a.results}: projection sd / sd {np.round(x.std(0, ddof=1) / sd, 3)}, fits' "
              f"{np.round(fit.std(0, ddof=1) / sd, 3)}, sd(fit - projection) / sd "
              f"{np.round((fit - x).std(0, ddof=1) / sd, 3)}")
        return
    x = np.array([vector(s)[2] for s in range(a.seed0, a.seed0 + a.n)])
    k, e = len(SPECTRA), model.expected(**p)
    mean = np.stack([e[s] for s in SPECTRA], 1).ravel()
    ratio = (x.var(0, ddof=1) / np.diag(cov)).reshape(-1, k)
    lo, hi = (chi2.ppf(q, a.n - 1) / (a.n - 1) for q in (0.025, 0.975))
    print(f"band, first bin, bins: variance / the fit's of {SPECTRA} (95 % [{lo:.2f}, {hi:.2f}]); mean / model")
    for b, bins in enumerate(bands.bands):
        print(b, bins[0], bins.size, np.round(ratio[b], 2), np.round((x.mean(0) / mean).reshape(-1, k)[b], 3))
    c, d = np.corrcoef(x.T), np.sqrt(np.diag(cov))
    print("uu neighbour-band correlation, records / fit:", [(round(float(c[b * k, (b + 1) * k]), 2), round(float(
        cov[b * k, (b + 1) * k] / d[b * k] / d[(b + 1) * k]), 2)) for b in range(len(bands.bands) - 1)])
    z = (x - mean) @ gls.T / sd
    print(f"projection sd / sd {np.round(z.std(0, ddof=1), 3)} (se {1 / math.sqrt(2 * a.n):.3f}); |z| < 1.96 in "
          f"{np.round(np.mean(np.abs(z) < 1.959964, 0), 3)}")

if __name__ == "__main__":
    main()
