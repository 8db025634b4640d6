"""Runner files a load engineer won't trip over (issue 37 §4): the two senses of a direction (--veer and direction
columns counter-clockwise, TurbSim's; WindDir and a transient's "+" clockwise, InflowWind's) named in every option's
help and in the written files, and a warning when a transient goes into a periodic file (it recurs every record)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

import turbgen
from turbgen.cli import cli
from turbgen.exporters.bts import read_bts

CCW, CW = "counter-clockwise seen from above", "clockwise seen from above"


def _option_help(args: list[str]) -> dict:
    import click

    command = cli
    for name in args:
        command = command.get_command(click.Context(command), name)
    return {p.opts[0]: " ".join((p.help or "").split()) for p in command.params if hasattr(p, "help")}


@pytest.mark.parametrize("args, options", [
    (["export"], {"--veer": CCW, "--profile": CCW, "--mean-history": CCW, "--transient-sign": CW}),
    (["transient"], {"--sign": CW}),
    (["lidar", "run"], {"--veer": CCW, "--mean-history": CCW}),
])  # fmt: skip
def test_every_direction_option_names_both_senses(args, options):
    helps = _option_help(args)
    for option, sense in options.items():
        assert sense in helps[option], (option, helps[option])
        other = "InflowWind's WindDir is clockwise" if sense == CCW else "counter-clockwise"
        assert other in helps[option], (option, helps[option])


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("conventions") / "k.zarr"
    turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 50], out=path)
    return path


def test_written_files_name_the_sense_of_their_angles(store, tmp_path):
    turbgen.export(store, "bts", tmp_path / "v.bts", veer=-0.1)
    assert "veer -0.1 deg/m; angles ccw from above" in read_bts(tmp_path / "v.bts")["description"]
    turbgen.export(store, "bts", tmp_path / "e.bts", transient="ECD", iec_class="IIB", rotor_diameter=40.0,
                   periodic=False)
    assert "sign +1 = cw from above" in read_bts(tmp_path / "e.bts")["description"]
    res = CliRunner().invoke(cli, ["transient", "EDC", "--iec-class", "IIB", "--U", "12", "--hub-height", "90",
                                   "--rotor-diameter", "126", "--out", str(tmp_path / "e.hh"), "--no-runner-files"])
    assert res.exit_code == 0, res.output
    header = " ".join(line for line in (tmp_path / "e.hh").read_text().splitlines() if line.startswith("!"))
    assert f"WindDir positive {CW}" in header and "counter-clockwise" in header


@pytest.mark.parametrize("fmt, out", [("bts", "t.bts"), ("wnd", "t"), ("hawc2", "h")])
def test_a_transient_in_a_periodic_file_is_warned_of(store, tmp_path, fmt, out):
    result = turbgen.export(store, fmt, tmp_path / out, transient="EOG", iec_class="IIB", rotor_diameter=40.0)
    warnings = [n for n in result.notes if n.startswith("warning: ")]
    assert len(warnings) == 1 and "EOG recurs every 32 s record" in warnings[0], result.notes
    if fmt != "hawc2":  # HAWC2 boxes are periodic whatever the option
        once = turbgen.export(store, fmt, tmp_path / ("n" + out), transient="EOG", iec_class="IIB",
                              rotor_diameter=40.0, periodic=False)
        assert not [n for n in once.notes if n.startswith("warning: ")], once.notes


def test_the_command_prints_the_warning_as_a_warning(store, tmp_path):
    res = CliRunner().invoke(cli, ["export", str(store), "--format", "bts", "--out", str(tmp_path / "c.bts"),
                                   "--transient", "EOG", "--iec-class", "IIB", "--rotor-diameter", "40"])
    assert res.exit_code == 0, res.output
    assert any(line.startswith("warning: the file is periodic") for line in res.stderr.splitlines()), res.stderr
