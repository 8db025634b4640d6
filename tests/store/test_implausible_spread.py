"""A store whose recorded rms exceeds any standard deviation a run may ask for: ``info`` shows it with a warning
(issue 37: constraint values of 1e30 m/s gave sigma_u = 2.6e29 m/s, shown without one). Such inputs are refused
now (tests/cli/test_bad_input.py); the Mann ranges' extreme corner still makes one."""

from __future__ import annotations

import json

from click.testing import CliRunner

import turbgen
from turbgen.cli import cli
from turbgen.store.plausibility import spread_warnings
from turbgen.theory import ranges

SMALL = {"nt": 64, "ny": 4, "nz": 4, "planes": [0, 50]}


def test_spread_warnings_name_each_component_beyond_the_sigma_range():
    hi = ranges.RANGES["sigma_m_s"].hi
    warnings = spread_warnings({"rms_m_s": {"u": 2.6e29, "v": hi, "w": float("nan")}})
    assert [w.split(":")[0] for w in warnings] == ["u", "w"]  # v at the bound passes; NaN is no plausible rms
    assert "2.6e+29 m/s is implausible" in warnings[0] and f"beyond {hi:g} m/s" in warnings[0]
    assert spread_warnings({}) == []  # a store written before rms_m_s


def test_info_warns_of_an_implausible_spread_and_not_of_a_plausible_one(tmp_path):
    # ae 100 at L = 1000 m, Gamma = 20: within every range, yet sigma_u ~ 450 m/s in the model
    wild, tame = tmp_path / "wild.zarr", tmp_path / "tame.zarr"
    turbgen.mann(**SMALL, ae=100, L=1000, gamma=20, out=wild)
    turbgen.mann(**SMALL, ae=0.3, out=tame)
    res = CliRunner().invoke(cli, ["info", str(wild)])
    assert res.exit_code == 0, res.output
    assert [line.split()[1] for line in res.output.splitlines() if line.startswith("warning")] == ["u:", "v:"]
    assert json.loads(CliRunner().invoke(cli, ["info", "--json", str(wild)]).output)["warnings"]
    res = CliRunner().invoke(cli, ["info", str(tame)])
    assert res.exit_code == 0 and "warning" not in res.output
