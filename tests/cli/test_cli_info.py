"""`turbgen info STORE`: readable summary, --json, one-line refusal with exit code 2."""

from __future__ import annotations

import json

import numpy as np
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.grid import Grid
from turbgen.store import create_store

GRID = Grid(nt=8, dt_s=0.5, x_m=(0.0, 50.0), ny=3, nz=2, dy_m=5.0, dz_m=4.0)
ATTRS = {
    "model": "kaimal",
    "parameters": {"sigma_u_m_s": 1.6, "a_yz": 12.0, "long_model": "exp"},
    "units": {"sigma_u_m_s": "m s-1", "a_yz": "1", "long_model": ""},
    "seed": 42,
    "U_m_s": 12.0,
    "hub_height_m": 90.0,
}


def make_store(path):
    with create_store(path, GRID, ATTRS) as w:
        for c in "uvw":
            for ix in range(GRID.nx):
                w.write(c, ix, np.ones((GRID.nt, GRID.ny, GRID.nz)))
    return path


def test_info_prints_summary(tmp_path):
    path = make_store(tmp_path / "k.zarr")
    result = CliRunner().invoke(cli, ["info", str(path)])
    assert result.exit_code == 0, result.output
    out = result.output
    for expected in (
        "model    kaimal, seed 42",
        "complete,",
        "(t, x, y, z) = 8 x 2 x 3 x 2",
        "dt 0.5 s, duration 4 s",
        "x = 0, 50 m upstream of the rotor",
        "U 12 m/s, hub height 90 m",
        "sigma_u_m_s  1.6 m s-1",
        "long_model   exp",
        "convected",
    ):
        assert expected in out, (expected, out)
    assert "a_yz         12\n" in out  # dimensionless: no unit printed


def test_info_json(tmp_path):
    path = make_store(tmp_path / "k.zarr")
    result = CliRunner().invoke(cli, ["info", str(path), "--json"])
    assert result.exit_code == 0, result.output
    s = json.loads(result.output)
    assert s["complete"] is True and s["model"] == "kaimal" and s["seed"] == 42
    assert s["grid"]["x_m"] == [0.0, 50.0] and s["duration_s"] == 4.0
    assert s["units"]["sigma_u_m_s"] == "m s-1" and s["parameters"]["a_yz"] == 12.0
    assert s["size_uncompressed_bytes"] == 3 * 8 * 2 * 3 * 2 * 4 and s["size_on_disk_bytes"] > 0


def test_info_bad_paths_exit_2_one_line(tmp_path):
    runner = CliRunner()
    result = runner.invoke(cli, ["info", str(tmp_path / "missing.zarr")])
    assert result.exit_code == 2
    assert result.stderr.strip().count("\n") == 0 and "no such store" in result.stderr
    path = make_store(tmp_path / "k.zarr")
    meta = json.loads((path / "zarr.json").read_text())
    del meta["attributes"]["turbgen_complete"]
    (path / "zarr.json").write_text(json.dumps(meta))
    result = runner.invoke(cli, ["info", str(path)])
    assert result.exit_code == 2 and "incomplete" in result.stderr
