"""`turbgen info FILE` on exported files: the mean wind and a non-periodic start shift are printed."""

from __future__ import annotations

import json

from click.testing import CliRunner

from export_fixtures import make_store
from turbgen.cli import cli


def info(*args):
    return CliRunner().invoke(cli, ["info", *map(str, args)])


def test_info_on_exports(tmp_path):
    path, _ = make_store(tmp_path / "s.zarr")
    res = CliRunner().invoke(cli, ["export", str(path), "--format", "bts", "--out", str(tmp_path / "f.bts"),
                                   "--profile", "log:z0=0.1", "--veer", "0.3", "--no-periodic"])
    assert res.exit_code == 0, res.output
    res = info(tmp_path / "f.bts")
    assert res.exit_code == 0, res.output
    assert "NOT periodic" in res.output and "(t, y, z) = 64 x 5 x 7, dt 0.1 s" in res.output
    assert "log law z0 = 0.1 m, d = 0 m; veer 0.3 deg/m" in res.output and "starts 0.4 s upstream" in res.output
    res = info(tmp_path / "f_InflowWind_bts.dat", "--json")
    doc = json.loads(res.output)
    assert "WindType 3" in doc["file"] and doc["wind file"] == '"f.bts" (relative to this file)'
    assert doc["title"].startswith("NOT PERIODIC: starts 0.4 s upstream")
    (tmp_path / "x.txt").write_text("hello\n")
    (tmp_path / "bad.bts").write_bytes(b"\x00" * 10)
    for bad, msg in [("x.txt", "neither a store nor a file"), ("bad.bts", "cannot be read as an export")]:
        res = info(tmp_path / bad)
        assert res.exit_code == 2 and msg in res.output and len(res.output.strip().splitlines()) == 1
