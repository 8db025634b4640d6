"""turbgen sweep --lidar: the virtual lidar on every field, its numbers in the manifest."""

import json

from click.testing import CliRunner

from turbgen.cli import cli

ARGS = ["sweep", "--model", "mann", "--preset", "neutral", "--speeds", "16", "--seeds", "1", "--nt", "512",
        "--ny", "32", "--nz", "32", "--workers", "1"]


def test_sweep_runs_the_lidar_and_records_it(tmp_path):
    out = tmp_path / "sw"
    r = CliRunner().invoke(cli, [*ARGS, "--lidar", "nacelle-4beam", "--out", str(out)])
    assert r.exit_code in (0, 3), r.output  # 3 only if the coherence verdict failed
    rec = json.loads((out / "manifest.json").read_text())["runs"][0]
    lid = rec["lidar"]
    assert set(lid) >= {"passed", "simulated", "theory"}
    assert 0.005 < lid["simulated"]["k05_rad_m"] < 0.1 and 0.005 < lid["theory"]["k05_rad_m"] < 0.1
    assert (r.exit_code == 3) is (not lid["passed"])
    assert "lidar over 1 fields" in r.output
    # a rerun keeps the complete store and its lidar record (nothing recomputed)
    r2 = CliRunner().invoke(cli, [*ARGS, "--lidar", "nacelle-4beam", "--out", str(out)])
    assert json.loads((out / "manifest.json").read_text())["runs"][0]["action"] == "skipped", r2.output


def test_sweep_with_an_unknown_lidar_writes_nothing(tmp_path):
    out = tmp_path / "sw"
    r = CliRunner().invoke(cli, [*ARGS, "--lidar", "no-such-lidar", "--out", str(out)])
    assert r.exit_code == 2
    assert "no-such-lidar" in r.output and "Traceback" not in r.output
    assert not out.exists() or not any(out.iterdir())
