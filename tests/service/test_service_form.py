"""The run form of the service's page (turbgen.service.form, form_request): one field per run option of the commands,
and the request body, command and Python call it shows describe one and the same run."""

from __future__ import annotations

import ast
import shlex

import pytest

from turbgen.cli.kaimal import kaimal
from turbgen.cli.mann import mann
from turbgen.spec.run_mapping import kaimal_run, mann_run_mapping
from turbgen.cli import kaimal as kaimal_cli, mann as mann_cli
from turbgen.errors import ParameterError
from turbgen.service.form import form_description, form_fields
from turbgen.service.form_request import form_request
from turbgen.service.run_ids import build_run
from turbgen.spec.kaimal import OPTIONS as KAIMAL_OPTIONS
from turbgen.spec.kaimal import REPLACES as KAIMAL_REPLACES
from turbgen.spec.kaimal import KaimalRun
from turbgen.spec.mann import OPTIONS as MANN_OPTIONS
from turbgen.spec.mann import REPLACES as MANN_REPLACES
from turbgen.spec.mann import MannRun
from turbgen.spec.run_inputs import merge_run_inputs
from turbgen.spec.run_mapping import run_inputs

# options of the commands that do not describe the run: where it goes, how it is computed, where inputs come from
NOT_A_RUN_OPTION = {
    "out": "the service chooses every output path (its catalog)",
    "overwrite": "a run is never recomputed, a store never replaced",
    "chunks": "never changes the field; the service chooses the store's chunks",
    "threads": "never changes the field; the server's cluster computes",
    "memory": "never changes the field; the server's --memory-budget bounds every run",
    "scheduler": "the server's own cluster runs every run",
    "stencil_cache": "the server keeps its own stencil cache",
    "config": "the form is the run file: every key of the run schema is a field",
    "presets_file": "a client's file is not read; the built-in presets are offered",
    "fft_backend": "the server's backend (its TURBGEN_FFT_BACKEND) makes every run; it moves a field by round-off only",
}
# the service conditions Mann runs only; a user spectrum or yz coherence is a table sent in the request body
# (form.NOT_IN_FORM), never a file name the server would read
RUN_OPTIONS = {"mann": mann_cli.RUN_OPTIONS, "kaimal": kaimal_cli.RUN_OPTIONS}
KAIMAL_NOT_IN_SERVICE = {"constrain", "noise", "conditional_mean", "spectrum", "coherence"}
MANN_NOT_IN_SERVICE: set = set()  # every option (since a run's ``fit`` key, the replay too)
COMMANDS = {"mann": (mann, MannRun, MANN_OPTIONS, MANN_REPLACES), "kaimal": (kaimal, KaimalRun, KAIMAL_OPTIONS,
                                                                          KAIMAL_REPLACES)}  # fmt: skip


@pytest.mark.parametrize("model", ["mann", "kaimal"])
def test_the_form_has_a_field_for_every_run_option_of_the_command(model):
    command = COMMANDS[model][0]
    options = {p.name for p in command.params if p.name not in NOT_A_RUN_OPTION}
    options -= KAIMAL_NOT_IN_SERVICE if model == "kaimal" else MANN_NOT_IN_SERVICE
    fields = {f.name for f in form_fields(model)}
    assert options - fields == set(), f"turbgen {model} options without a form field"
    assert fields - options == set(), f"form fields that are no option of turbgen {model}"
    assert set(NOT_A_RUN_OPTION) <= {p.name for p in mann.params}  # the exclusions are real options
    assert len(mann.params) == 36 and len(fields) == {"mann": 26, "kaimal": 23}[model]


def test_every_field_shows_its_range_unit_and_meaning():
    for model, fields in form_description(token_required=False)["models"].items():
        for f in fields:
            assert f["help"], (model, f["name"])
            if f["kind"] in ("number", "integer", "list3", "positions", "evo"):
                assert f["range"].startswith(("[", "(")), (model, f)
    mann_fields = {f.name: f for f in form_fields("mann")}
    assert (mann_fields["L"].range, mann_fields["L"].unit, mann_fields["L"].key) == ("[1, 1000]", "m", "length_scale_m")
    assert mann_fields["hub_height"].flag == "--hub-height" and mann_fields["sigma_u"].unit == "m/s"
    assert {f.name: f.flag for f in form_fields("kaimal")}["turb_class"] == "--class"


VALUES = {
    "mann": {"L": "30", "gamma": "2.5", "evo": "frozen", "lifetime": "mann", "ti": "0.12", "nt": "128", "dt": "0.25",
             "ny": "6", "nz": "4", "dy": "3", "gates": "40:60:10", "U": "9", "hub_height": "80", "seed": "7",
             "pad_yz": "1", "preset": "stable"},
    "kaimal": {"sigma": "1, 0.8 ,0.5", "lengths": "340,113,27.7", "ayz": "10", "lc": "70", "ax": "2", "bx": "0.0002",
               "long_components": "uvw", "vw_coherence": "exp", "rescale": "true", "nt": "128", "ny": "5",
               "nz": "5", "planes": "0,30", "U": "12", "hub_height": "100", "seed": "3", "preset": "unstable"},
}  # fmt: skip


@pytest.mark.parametrize("model", ["mann", "kaimal"])
def test_the_command_and_the_python_call_make_the_run_of_the_body(model):
    command, spec, options, replaces = COMMANDS[model]
    out = form_request(model, VALUES[model])
    _, run, _ = build_run(out["body"])
    # the command, parsed by the command itself
    words = shlex.split(out["command"])
    assert words[:2] == ["turbgen", model]
    opt = command.make_context(model, words[2:]).params
    # the run as the command makes it from its options (turbgen.spec.run_mapping.mann_run_mapping / kaimal_run)
    given_options = {name: opt[name] for name in RUN_OPTIONS[model]}
    if model == "mann":
        assert MannRun.from_mapping(mann_run_mapping(given_options, None, opt["preset"])[0]) == run
    else:
        assert kaimal_run(given_options, None, opt["preset"])[0] == run
    from turbgen.spec.preset_runs import run_keys
    # the Python call's keywords, taken as turbgen.<model>() takes them
    call = ast.parse(out["python"]).body[1].value
    assert ast.unparse(call.func) == f"turbgen.{model}"
    kwargs = {k.arg: ast.literal_eval(k.value) for k in call.keywords}
    given, grid, x_m = run_inputs(model, {k: v for k, v in kwargs.items() if k != "preset"})
    keys = lambda mapping, g: run_keys(model, kwargs["preset"], g.get("U_m_s", 16.0))  # noqa: E731
    assert spec.from_mapping(merge_run_inputs(None, given, grid, preset_keys=keys, replaces=replaces, x_m=x_m)) == run
    assert run.seed == int(VALUES[model]["seed"])


@pytest.mark.parametrize(("values", "message"), [
    ({"L": "fast"}, "L: 'fast' is not a number"),
    ({"nt": "12.5"}, "nt: '12.5' is not an integer"),
    ({"planes": "0,50", "gates": "50:100:10"}, "gates: give planes or gates, not both"),
    ({"gates": "50:10:10"}, "gates = '50:10:10' needs finite numbers, step > 0 and stop >= start"),
    ({"dy": "nan"}, "dy: 'nan' is not a finite number"),
    ({"outdir": "x"}, "outdir: not a field of the mann form"),
])  # fmt: skip
def test_a_bad_value_is_refused_naming_its_field(values, message):
    with pytest.raises(ParameterError) as err:
        form_request("mann", values)
    assert str(err.value) == message


def test_the_snapshot_marks_the_measurement_points_of_its_plane_only():
    from types import SimpleNamespace

    from turbgen.service.field_view import _measurement_points

    streams = [{"name": "a", "x_m": 0.0, "y_m": 1.0, "z_m": 2.0, "plane": 0},
               {"name": "b", "x_m": 50.0, "y_m": 0.0, "z_m": 0.0, "plane": 1},
               {"name": "los", "x_m": 0.0, "y_m": None, "z_m": None, "plane": 0},
               {"name": "turned", "x_m": 49.24, "y_m": 8.68, "z_m": 0.0, "plane": 1}]  # fmt: skip
    constrained = SimpleNamespace(attrs={"constraints": {"streams": streams}})
    assert [s["name"] for s in _measurement_points(constrained, 0)] == ["a"]
    # a replay's sensor turned into the wind's frame: on plane 1 (its file's x, 50 m) at its turned x
    assert [s["name"] for s in _measurement_points(constrained, 1)] == ["b", "turned"]
    assert _measurement_points(SimpleNamespace(attrs={}), 0) == []


@pytest.mark.parametrize("key", ["spectrum", "coherence"])
def test_a_table_given_as_a_file_name_is_refused_before_any_file_is_read(key, tmp_path):
    """A request naming a server file for a user table is one ParameterError line; the file is never opened (it
    does not exist: a read would say so instead)."""
    from turbgen.errors import ParameterError
    from turbgen.service.run_ids import build_run

    with pytest.raises(ParameterError, match=key) as info:
        build_run({"model": "kaimal", key: str(tmp_path / "site.csv")})
    assert "does not exist" not in str(info.value) and "\n" not in str(info.value)
