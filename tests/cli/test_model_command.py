"""turbgen.cli.model: the command a declared model without its own gets (turbgen.spec.models, ``command`` None)."""

import numpy as np
from click.testing import CliRunner

import turbgen
import turbgen.cli
from turbgen.cli import cli

ARGS = ["--U", "12", "--seed", "5", "--nt", "64", "--ny", "4", "--nz", "4", "--dy", "6", "--planes", "0,30"]


def test_the_built_command_makes_the_field_of_the_models_own(tmp_path, monkeypatch):
    own = CliRunner().invoke(cli, ["kaimal", *ARGS, "--ayz", "10", "--out", str(tmp_path / "own.zarr")])
    assert own.exit_code == 0, own.output
    monkeypatch.setitem(turbgen.cli.COMMANDS, "kaimal", ("turbgen.cli.model", "model_command"))
    built = CliRunner().invoke(cli, ["kaimal", *ARGS, "--ayz", "10", "--out", str(tmp_path / "built.zarr")])
    assert built.exit_code == 0 and built.output == f"wrote {tmp_path / 'built.zarr'}\n", built.output
    a, b = turbgen.open_store(tmp_path / "own.zarr"), turbgen.open_store(tmp_path / "built.zarr")
    for c in ("u", "v", "w"):
        np.testing.assert_array_equal(a[c].values, b[c].values)  # same run, same seed: bit for bit
    assert a.attrs["parameters"] == b.attrs["parameters"]
    bad = CliRunner().invoke(cli, ["kaimal", "--nt", "1", "--out", str(tmp_path / "bad.zarr")])
    assert bad.exit_code == 2 and len(bad.output.strip().splitlines()) == 1 and "nt" in bad.output, bad.output
    assert not (tmp_path / "bad.zarr").exists()
