"""Speed of the lidar preview theory: gamma^2_RL of the Guo et al. (2023) Table 3 lidar at 60 frequencies.

Target (issue): <= 10 s on the 2-core machine. Prints wall time, the machine's load average, and the
cut-off so the number is checked, not only timed.
"""

import os
import time

import numpy as np

from turbgen.virtual_lidar.description import PRESETS
from turbgen.virtual_lidar.preview import preview_spectra
from turbgen.theory.lidar_control import cutoff_frequency_hz


def main():
    f = np.geomspace(0.005, 0.3, 60)
    for model in ("mann", "kaimal"):
        t0 = time.perf_counter()
        S = preview_spectra(model, PRESETS["nacelle-4beam"], 16.0, f_hz=f)
        dt = time.perf_counter() - t0
        print(f"{model:7s} neutral 16 m/s, 60 frequencies: {dt:5.1f} s (load {os.getloadavg()[0]:.1f}); "
              f"cut-off {cutoff_frequency_hz(f, S.G_RL):.4f} Hz")


if __name__ == "__main__":
    main()
