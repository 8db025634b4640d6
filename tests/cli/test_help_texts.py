"""--help texts that say what the commands do (issue 37 §3): no summary cut at an abbreviation's period, one default
frequency grid per command, --json described, --iec-class for the turbine class everywhere (--class a deprecated
alias in sweep and transient), one default hub height, and --evo frozen wherever --evo is taken."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import click
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.spec.defaults import KAIMAL_DEFAULTS, MANN_DEFAULTS


def _commands(group: click.Group, path=()):
    ctx = click.Context(group)  # the group loads its commands lazily: list and get them, not .commands
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        yield (*path, name), command
        if isinstance(command, click.Group):
            yield from _commands(command, (*path, name))


def test_the_walk_reaches_every_command():
    names = {" ".join(path) for path, _ in _commands(cli)}
    assert {"transient", "theory coherence", "fit kaimal", "fit evolution", "lidar optimize", "serve"} <= names


@pytest.mark.parametrize("limit", [45, 200])  # the group listing's width, and a wide terminal
def test_no_summary_ends_at_an_abbreviation(limit):
    cut = re.compile(r"(\bEq|\bEd|\bet al|\be\.g|\bi\.e|\bSect|\bFig)\.$")
    for path, command in _commands(cli):
        short = command.get_short_help_str(limit=limit)
        assert not cut.search(short), (path, short)  # "Write the IEC 61400-1 Ed.", "coh2 (Eq."


def test_every_group_lists_its_commands_whole_on_an_80_column_terminal():
    for path, command in [((), cli), *((p, c) for p, c in _commands(cli) if isinstance(c, click.Group))]:
        res = CliRunner().invoke(cli, [*path, "--help"], terminal_width=80)
        listing = res.output.split("Commands:")[1]
        assert res.exit_code == 0 and not [line for line in listing.splitlines() if line.endswith("...")], res.output


def test_json_help_says_what_it_prints_and_fit_kaimal_states_one_grid():
    for path, command in _commands(cli):
        for param in command.params:
            assert "README" not in (getattr(param, "help", None) or ""), (path, param.name)
    res = CliRunner().invoke(cli, ["fit", "kaimal", "--help"], terminal_width=200)
    text = " ".join(res.output.split())
    assert "1000 linear steps, 1e-3..1 Hz" in text and "log-spaced" not in text, text
    res = CliRunner().invoke(cli, ["fit", "evolution", "--help"], terminal_width=200)
    text = " ".join(res.output.split())
    assert text.count("60 log-spaced, 3e-4..0.5 Hz") == 1 and "40 log-spaced" not in text, text


def test_the_turbine_class_is_iec_class_and_class_its_deprecated_alias(tmp_path):
    args = ["transient", "EOG", "--U", "12", "--hub-height", "90", "--rotor-diameter", "126", "--no-runner-files"]
    new = CliRunner().invoke(cli, [*args, "--iec-class", "IIB", "--out", str(tmp_path / "a.hh")])
    old = CliRunner().invoke(cli, [*args, "--class", "IIB", "--out", str(tmp_path / "b.hh")])
    assert new.exit_code == 0 and old.exit_code == 0, (new.output, old.output)
    assert "deprecated" not in new.stderr and "--class is deprecated here, write --iec-class IIB" in old.stderr
    assert (tmp_path / "a.hh").read_bytes() == (tmp_path / "b.hh").read_bytes()
    both = CliRunner().invoke(cli, [*args, "--iec-class", "IIB", "--class", "IIB", "--out", str(tmp_path / "c.hh")])
    assert both.exit_code == 2 and not (tmp_path / "c.hh").exists()
    none = CliRunner().invoke(cli, [*args, "--out", str(tmp_path / "d.hh")])
    assert none.exit_code == 2 and "missing option --iec-class" in none.stderr
    for command in (["transient"], ["sweep"]):
        res = CliRunner().invoke(cli, [*command, "--help"], terminal_width=200)
        assert "--iec-class" in res.output and "--class " not in res.output, res.output  # the alias is hidden


def test_one_default_hub_height():
    assert MANN_DEFAULTS["hub_height_m"] == KAIMAL_DEFAULTS["hub_height_m"] == 150.0
    for command in ("mann", "kaimal"):
        res = CliRunner().invoke(cli, [command, "--help"], terminal_width=200)
        assert "default 150)" in " ".join(res.output.split()), res.output


def test_lidar_optimize_takes_evo_frozen():
    args = ["lidar", "optimize", "--ranges", "100", "--cones", "10", "--json"]
    frozen = CliRunner().invoke(cli, [*args, "--evo", "frozen"])
    evolving = CliRunner().invoke(cli, [*args, "--evo", "400"])
    assert frozen.exit_code == 0 and evolving.exit_code == 0, (frozen.output, evolving.output)
    k_frozen = json.loads(frozen.stdout)["candidates"][0]["k05_rad_m"]
    k_400 = json.loads(evolving.stdout)["candidates"][0]["k05_rad_m"]
    assert k_frozen > k_400  # no eddy evolution: the lidar preview stays coherent to smaller eddies


LIST = """
import sys
from turbgen.cli import main
sys.argv = ["turbgen", "--help"]
try:
    main()
except SystemExit:
    pass
heavy = ("turbgen.validation", "turbgen.runs", "turbgen.synthesis", "turbgen.store", "zarr", "numba", "xarray")
print("IMPORTED", *[m for m in heavy if m in sys.modules])
"""


def test_the_command_list_is_each_command_s_summary_and_imports_none():
    """``turbgen --help`` lists the commands from SUMMARIES without importing them (all of them took ~3.5 s), and an
    imported command's own short help is that summary, so the two listings cannot differ."""
    from turbgen.cli import COMMANDS, SUMMARIES

    out = subprocess.run([sys.executable, "-c", LIST], capture_output=True, text=True, check=True).stdout
    assert out.splitlines()[-1] == "IMPORTED", out
    lines = {line.split()[0]: " ".join(line.split()[1:]) for line in out.split("Commands:")[1].splitlines()[1:-1]}
    assert lines == SUMMARIES and set(SUMMARIES) == set(COMMANDS), out  # one line each at 80 columns, none cut
    for path, command in _commands(cli):
        if len(path) == 1:
            assert command.get_short_help_str(limit=200) == SUMMARIES[path[0]], path
