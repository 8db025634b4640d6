"""Lidar datasets made with a general mean wind (`turbgen lidar run --mean-wind --profile ... --mean-history ...`)
constrain a field with that same mean wind removed (the MeanWind the dataset records), and a field so constrained
re-measures the data; a dataset whose mean wind turns is refused with one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from test_lidar_constraints import GRID, LIDAR
from turbgen.cli import cli
from turbgen.virtual_lidar.dataset import read_dataset
from turbgen.spec.mean_wind import MeanWind

# the Mann default U is 16 m/s; the record is 256 x 0.5 s
WIND = ["--mean-wind", "--profile", "log:z0=0.05,d=2", "--mean-history", "HIST"]


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    d = tmp_path_factory.mktemp("loop_mw")
    (d / "small.json").write_text(json.dumps(LIDAR))
    (d / "hub.csv").write_text("t,U\n5,15\n60,18\n120,16.5\n")
    wind = [str(d / "hub.csv") if a == "HIST" else a for a in WIND]
    r = CliRunner()
    for args in (["mann", *GRID, "--seed", "1", "--out", str(d / "truth.zarr")],
                 ["lidar", "run", str(d / "truth.zarr"), "--lidar", str(d / "small.json"), "--rotor-radius", "10",
                  *wind, "--out", str(d / "truth_lidar.zarr")],
                 ["lidar", "run", str(d / "truth.zarr"), "--lidar", str(d / "small.json"), "--rotor-radius", "10",
                  *wind, "--veer", "-0.2", "--out", str(d / "veer_lidar.zarr")]):  # fmt: skip
        res = r.invoke(cli, args, prog_name="turbgen")
        assert res.exit_code in (0, 1), res.output  # lidar run: 1 = its coherence verdict, not an error
    return d, wind


def test_dataset_records_its_mean_wind(loop):
    d, _ = loop
    record = read_dataset(d / "truth_lidar.zarr").mean_wind
    wind = MeanWind.from_attrs(record)
    assert wind.profile == "log" and wind.roughness_m == 0.05 and wind.history_speeds_m_s == (15.0, 18.0, 16.5)


def test_constrained_field_reproduces_the_lidar_data_with_its_mean_wind(loop):
    d, wind = loop
    r = CliRunner()
    res = r.invoke(cli, ["mann", *GRID, "--seed", "2", "--constrain", str(d / "truth_lidar.zarr"),
                         "--out", str(d / "c.zarr")], prog_name="turbgen")  # fmt: skip
    assert res.exit_code == 0, res.output
    res = r.invoke(cli, ["lidar", "run", str(d / "c.zarr"), "--lidar", str(d / "small.json"), "--rotor-radius", "10",
                         *wind, "--out", str(d / "re.zarr")], prog_name="turbgen")  # fmt: skip
    assert res.exit_code in (0, 1), res.output
    truth, again = read_dataset(d / "truth_lidar.zarr").v_los, read_dataset(d / "re.zarr").v_los
    # zero noise: the field passes through the data to float32 round-off (the bound of the power-law loop test)
    np.testing.assert_allclose(again, truth, rtol=0, atol=1e-4)


def test_turning_mean_wind_is_refused(loop):
    d, _ = loop
    res = CliRunner().invoke(cli, ["mann", *GRID, "--seed", "2", "--constrain", str(d / "veer_lidar.zarr"),
                                   "--out", str(d / "v.zarr")], prog_name="turbgen")  # fmt: skip
    assert res.exit_code == 2 and "its mean wind turns" in res.output and "Traceback" not in res.output
    assert not (d / "v.zarr").exists()
