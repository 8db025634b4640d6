"""Quickstart: a Mann 4D field, a Kaimal field, a validation, a TurbSim .bts and a spectrum plot, in Python.

Run it as ``python docs/examples/quickstart.py [DIRECTORY]`` (default: the current directory); the small grids take
seconds. tests/docs/test_quickstart.py runs it and checks that its stores and .bts file are bit-identical to those of
the equivalent commands (``turbgen mann --nt 512 --ny 16 --nz 16 --dy 8 --out ...``, ``turbgen export ...``).
"""

import sys

import matplotlib.pyplot as plt
from scipy.signal import welch

import turbgen

out = sys.argv[1] if len(sys.argv) > 1 else "."
mann = turbgen.mann(L=49, gamma=3.1, evo=400, nt=512, ny=16, nz=16, dy=8, out=f"{out}/mann_small.zarr")
kaimal = turbgen.kaimal(U=16, nt=512, ny=16, nz=16, dy=8, planes=[0, 50, 100], out=f"{out}/kaimal_small.zarr")
report = turbgen.validate(mann)
print(report.table())
turbgen.export(mann, "bts", f"{out}/mann_small.bts")
for name, field in (("Mann", mann), ("Kaimal", kaimal)):
    f, S = welch(field.u.isel(x=0).values, fs=1 / 0.5, nperseg=128, axis=0)  # dt = 0.5 s: the default
    plt.loglog(f[1:], (f * S.mean(axis=(1, 2)))[1:], label=name)
plt.xlabel("f [Hz]"), plt.ylabel("f S_u(f) [m²/s²]"), plt.legend()
plt.savefig(f"{out}/spectrum_u.png", dpi=100)
