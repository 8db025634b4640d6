"""The lidar loop at a tiny size (issue 26): the conditional mean of a Mann field given the Table 3 lidar's
measurements of another field explains at least the preview theory's gamma^2_RL of that field's rotor-effective wind.
benchmarks/lidar_loop.py runs the full comparison (sample, sonic, RMSE, figure)."""

from __future__ import annotations

import numpy as np
import pytest

import turbgen
from turbgen.virtual_lidar import signals
from turbgen.store import open_store

SMALL = dict(nt=256, ny=16, nz=16, dy=8.0, gates="50:170:13.3", config={"turb_class": "A"}, threads=1)  # the truth's ae


def _coherence_error(coh2: np.ndarray, n_eff: float) -> np.ndarray:
    """Largest standard deviation of a Welch magnitude-squared coherence estimate whose expectation is >= coh2:
    sigma(g^2) = sqrt(2) (1 - g^2) |g| / sqrt(n_d) (Bendat & Piersol 2010, Eq. 9.82, n_d independent segments; here
    the effective count of the 50 %-overlapped Hann segments), maximised over g^2 in [coh2, 1] (its maximum is at
    g^2 = 1/3)."""
    g2 = np.maximum(coh2, 1.0 / 3.0)
    return np.sqrt(2.0) * (1.0 - g2) * np.sqrt(g2) / np.sqrt(n_eff)


@pytest.mark.slow
def test_conditional_mean_explains_at_least_the_preview_coherence(tmp_path):
    turbgen.mann(seed=1, out=tmp_path / "truth.zarr", **SMALL)
    report = turbgen.lidar(tmp_path / "truth.zarr", out=tmp_path / "lidar.zarr")  # the default Table 3 lidar
    turbgen.mann(seed=2, out=tmp_path / "mean.zarr", constrain=[tmp_path / "lidar.zarr"], conditional_mean=True,
                 **SMALL)  # fmt: skip
    run = report.run
    t, radius, setup = run.t_arrival_s, run.rotor_radius_m, run.welch["setup"]
    truth = signals.rotor_average(open_store(tmp_path / "truth.zarr"), radius, t)[0]
    mean = signals.rotor_average(open_store(tmp_path / "mean.zarr"), radius, t)[0]
    w = signals.welch_rl(mean, truth, setup)
    theory = report.coh2_theory
    coh2 = w["coh2_RL"][1 : 1 + theory.size]  # the report's bins 1 .. (its f_hz)
    band = theory >= 0.1  # where the lidar previews anything
    assert band.sum() >= 2
    # E[coh2(mu, T)] = S_mu / S_T >= gamma^2_RL at each bin (mu = E[u_RR | every beam and gate] explains at least
    # what u_LL, one linear function of the same data, explains). The estimate over the band's m bins: its mean has
    # a standard deviation <= the largest single-bin one (bins positively correlated at worst); 3 of them.
    tolerance = 3.0 * _coherence_error(theory[band], w["n_eff"]).max()
    assert coh2[band].mean() >= theory[band].mean() - tolerance, (coh2, theory, tolerance)
    # the same measured, bin by bin, with the single-bin error
    assert np.all(coh2[band] >= theory[band] - 3.0 * _coherence_error(theory[band], w["n_eff"])), (coh2, theory)
    # and it is the lidar data that did it: for a field independent of the truth, P(coh2 > x) = (1 - x)^(n - 1) at
    # each bin (n independent segments, Carter et al. 1973); its 99.9 % quantile bounds the band mean of a no-op
    n = int(w["n_eff"])
    assert coh2[band].mean() > 1.0 - 0.001 ** (1.0 / (n - 1)), (coh2, n)
