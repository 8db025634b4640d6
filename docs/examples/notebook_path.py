"""The figure of docs/api.md's notebook path: a Mann field made in memory, its validation, and a field of another
seed conditioned on the virtual lidar's measurements of the first.

Run it as ``python docs/examples/notebook_path.py [PNG]`` (default ``notebook_path.png``); the grid is the page's.
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import turbgen  # noqa: E402

png = sys.argv[1] if len(sys.argv) > 1 else "notebook_path.png"
params = turbgen.MannParams(ae=0.1, length_scale_m=49, gamma=3.1, evo_time_s=400)
gates = [round(50 + 13.3 * i, 9) for i in range(10)]
grid = turbgen.Grid(nt=256, dt_s=0.5, x_m=(0, *gates), ny=16, nz=16, dy_m=8, dz_m=8)
g = turbgen.MannGenerator(params, grid, U_m_s=16, pad_yz=1)
a, b = g.fields([1, 2])
report = turbgen.validate(a)
lidar = turbgen.lidar(a)
c = turbgen.mann(ae=0.1, L=49, gamma=3.1, evo=400, nt=256, ny=16, nz=16, dy=8, planes=[0, *gates], pad_yz=1,
                 seed=2, constrain=[lidar])

fig, (ax0, ax1, ax2) = plt.subplots(1, 3, figsize=(15, 4))
im = ax0.pcolormesh(a.y, a.z, a.u.isel(t=0, x=0).T, shading="nearest", cmap="RdBu_r")
fig.colorbar(im, ax=ax0, label="u [m/s]")
ax0.set(xlabel="y [m]", ylabel="z [m]", title="a = g.field(1): u in the rotor plane, t = 0", aspect="equal")
curve = report.metric("spectrum_u").curves[0]
ax1.fill_between(curve.f_hz, curve.f_hz * curve.lower, curve.f_hz * curve.upper, alpha=0.3, lw=0, label="95 % band")
ax1.loglog(curve.f_hz, curve.f_hz * curve.estimate, label="estimate")
ax1.loglog(curve.f_hz, curve.f_hz * curve.expected, "k--", label="Mann model on the grid")
ax1.set(xlabel="f [Hz]", ylabel="f S_u(f) [m²/s²]", title="turbgen.validate(a): the u spectrum")
ax1.legend(fontsize=8)
point = dict(x=gates[4], y=a.y[len(a.y) // 2], z=a.z[len(a.z) // 2], method="nearest")
for field, label, style in ((a, "a (seed 1)", "k-"), (b, "b (seed 2)", "C0:"), (c, "c: seed 2 given a's lidar", "C3-")):
    ax2.plot(field.t, field.u.sel(**point), style, lw=1, label=label)
ax2.set(xlabel="t [s]", ylabel="u [m/s]", title=f"u at x = {gates[4]:g} m, rotor centre")
ax2.legend(fontsize=8)
fig.tight_layout()
fig.savefig(png, dpi=90)
print(png, report.passed)
