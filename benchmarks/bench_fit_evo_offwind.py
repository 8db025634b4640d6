"""The gamma a fit reads when it takes two masts' line for the wind's direction (docs/fit.md, "Masts off the wind's
line"): the co-coherence of u of two points d apart on a line theta off the wind (d cos theta along it, d sin theta
across), from the continuous model rho(k1, dx, dy) = sum Phi_11 exp(i k2 dy) exp(-dx / (U tau_e)) / sum Phi_11
(Guo et al. 2023, Eq. 8, 13, 16), least-squares matched over k1 (f 0.005-0.3 Hz at U = 10 m/s) by the model of
points d apart along the wind with no lateral offset. L = 30 m, Gamma = 3. Prints a markdown table.

Run: python benchmarks/bench_fit_evo_offwind.py"""

import math

import numpy as np
from scipy.optimize import minimize_scalar

from turbgen.theory.eddy_lifetime import evolution_lifetime_s
from turbgen.theory.mann_quadrature import perpendicular_quadrature
from turbgen.theory.params import MannParams

P = MannParams(ae=0.1, length_scale_m=30.0, gamma=3.0, evo_time_s=1.0)
U = 10.0
K1 = np.geomspace(2 * np.pi * 0.005 / U, 2 * np.pi * 0.3 / U, 30)
_, W0, G0 = perpendicular_quadrature(K1, P, ((0, 0),))
ONE_POINT = np.real(W0 * G0[(0, 0)]).sum(1)


def rho(gamma_s: float, dx: float, dy: float) -> np.ndarray:
    kappa, w, g = perpendicular_quadrature(K1, P, ((0, 0),), dy_m=dy)
    rate = 1.0 / evolution_lifetime_s(np.sqrt(K1[:, None] ** 2 + kappa**2), P)
    return np.real(w * g[(0, 0)] * np.exp(-rate * dx / (U * gamma_s))).sum(1) / ONE_POINT


def read_as(gamma_s: float, d: float, theta_deg: float) -> float:
    target = rho(gamma_s, d * math.cos(math.radians(theta_deg)), d * math.sin(math.radians(theta_deg)))
    fit = minimize_scalar(lambda x: np.sum((rho(math.exp(x), d, 0.0) - target) ** 2), method="bounded",
                          bounds=(math.log(5.0), math.log(1e4)))
    return math.exp(fit.x)


if __name__ == "__main__":
    print("| d [m] | off the wind [deg] | true gamma [s] | read as [s] |\n|---|---|---|---|")
    for d, theta in ((100, 2), (100, 5), (100, 10), (100, 20), (50, 10), (200, 10)):
        for gamma in (100.0, 400.0):
            print(f"| {d} | {theta} | {gamma:g} | {read_as(gamma, d, theta):.3g} |")
