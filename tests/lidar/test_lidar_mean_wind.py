"""The lidar adds the exports' mean wind (turbgen.spec.mean_wind.MeanWind): log profile, veer and a hub
history at each probe point, at the stored time of its slice, checked against the formula."""

import math

import numpy as np
import pytest
from click.testing import CliRunner

from test_lidar_sampling import GRID, U, make_store, schedule
from turbgen.cli import cli
from turbgen.virtual_lidar import sampling
from turbgen.virtual_lidar.sampling import Measurement
from turbgen.spec.mean_wind import MeanWind

HUB = 100.0


def test_log_profile_veer_and_history_at_the_probe(tmp_path):
    fs, d = make_store(tmp_path / "s.zarr")
    y, z = GRID.y(), GRID.z()
    a = np.deg2rad(15.0)
    n = (math.cos(a), math.sin(a), 0.0)  # sees u and v
    m = Measurement(0, 0, n, (40.0, y[6], z[5]), direction=(1.0, 0.0, 0.0))
    wind = MeanWind(profile="log", roughness_m=0.1, veer_deg_per_m=0.5, history_times_s=(0.0, 30.0),
                    history_speeds_m_s=(18.0, 24.0), history_directions_deg=(0.0, 12.0))
    t, b = schedule(40, 1, 0.5)
    s = sampling.sample(fs, [m], t, b, add_mean_wind=True, mean_wind=wind)
    h = HUB + z[5]
    k = s.v_los.shape[0]
    for i in range(k):
        ts = t[i] + 40.0 / U  # stored time: when this slice reaches the rotor
        speed = np.interp(ts, (0.0, 30.0), (18.0, 24.0))
        turn = math.radians(0.5 * (h - HUB) + np.interp(ts, (0.0, 30.0), (0.0, 12.0)))
        uu = d["u"][i + 4, 1, 6, 5] + speed * math.log(h / 0.1) / math.log(HUB / 0.1)
        vv = float(d["v"][i + 4, 1, 6, 5])
        exp = n[0] * (uu * math.cos(turn) - vv * math.sin(turn)) + n[1] * (uu * math.sin(turn) + vv * math.cos(turn))
        assert s.v_los[i, 0, 0] == pytest.approx(exp, abs=5e-6)  # float32 v_los
    assert s.mean_wind_added and s.mean_wind.startswith("log law z0 = 0.1 m")


def test_power_law_mean_wind_matches_the_shear_option(tmp_path):
    fs, _ = make_store(tmp_path / "s.zarr")
    m = Measurement(0, 0, (1.0, 0.0, 0.0), (40.0, 0.0, GRID.z()[6]), direction=(1.0, 0.0, 0.0))
    t, b = schedule(10, 1, 0.5)
    s0 = sampling.sample(fs, [m], t, b, add_mean_wind=True, shear_exponent=0.14)
    s1 = sampling.sample(fs, [m], t, b, add_mean_wind=True, mean_wind=MeanWind(shear_exponent=0.14))
    np.testing.assert_allclose(s1.v_los, s0.v_los, rtol=0, atol=1e-6)


def test_cli_profile_needs_mean_wind(tmp_path):
    fs, _ = make_store(tmp_path / "s.zarr")
    res = CliRunner().invoke(cli, ["lidar", "run", str(tmp_path / "s.zarr"), "--veer", "0.1"])
    assert res.exit_code == 2 and "--veer belong to --mean-wind" in res.output
    res = CliRunner().invoke(cli, ["lidar", "run", str(tmp_path / "s.zarr"), "--mean-wind", "--profile", "log:z0=0"])
    assert res.exit_code == 2 and "z0 (m) = 0.0 must be > 0" in res.output
