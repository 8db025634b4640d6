"""Time of `turbgen.fit_mann` on a 10-minute 20 Hz mast of four sensors (u, v, w), against the continuous model:
points of a turbgen field (L 30 m, Gamma 3.2, ae 0.08, frozen, U 10 m/s, dt 0.05 s, 32 x 32 nodes 4 m apart), a
36 m column (z nodes 4, 12, 20, 28) and an 8 m one (12, 14, 16, 18), Welch segments of 2048 samples. The points
of a 4 m box are not a sensor's (the box lacks the wavenumbers beyond its Nyquist, so the continuous fit misfits
them): this measures the time of the weights, whose cross-spectra between the sensors cost the most.

    python benchmarks/bench_fit_rate.py    # one JSON line per column: points, seconds, ae, L, Gamma, chi2/dof, ae 95 %
"""

import time, numpy as np, turbgen, json
ds = turbgen.mann(L=30, gamma=3.2, ae=0.08, evo="frozen", U=10, nt=12000, dt=0.05, ny=32, nz=32, dy=4, planes=[0],
                  hub_height=90, seed=3)
for ks in ((4, 12, 20, 28), (12, 14, 16, 18)):
    sensors = [dict(name=f"s{k}", x_m=0, y_m=float(ds.y[16]), z_m=float(ds.z[k]),
                    **{f"{c}_m_s": ds[c].values[:, 0, 16, k] for c in "uvw"}) for k in ks]
    ps = turbgen.point_series(ds.t.values, sensors)
    t0 = time.time(); f = turbgen.fit_mann(ps, U=10, nperseg=2048); t = time.time() - t0
    print(json.dumps([ks, round(t, 1), f.ae.value, f.length_scale_m.value, f.gamma.value, f.chi2_dof, *f.ae.ci95]))
