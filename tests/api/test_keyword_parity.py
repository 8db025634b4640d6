"""Every option of the field commands is a keyword of the API function with the same name, meaning and default:
the click commands (turbgen.cli) walked and compared with the functions' signatures."""

import inspect

import click
import pytest

import turbgen
from turbgen.cli import cli

# command path -> API function
COMMANDS = {("mann",): turbgen.mann, ("kaimal",): turbgen.kaimal, ("validate",): turbgen.validate,
            ("export",): turbgen.export, ("lidar", "run"): turbgen.lidar, ("info",): turbgen.info,
            ("fit", "mann"): turbgen.fit_mann}
# option flags with no keyword, and why
NOT_KEYWORDS = {
    "--json": "presentation: the API returns the report or summary (to_dict())",
    "--scheduler": "dask orchestration of out-of-core runs from the command line",
}
# per command: flags with no keyword there, and why
COMMAND_NOT_KEYWORDS = {("fit", "mann"): {"--plots": "the result's plot(path) writes the figure",
                                          "--overwrite": "of --plots' figure"}}
# flags that are not Python names
RENAMED = {"--class": "turb_class", "--point": "points"}


def _command(path):
    ctx = click.Context(cli)
    command = cli
    for name in path:
        command = command.get_command(ctx, name)
    return command


def _keyword(param: click.Parameter, path=()) -> str | None:
    if isinstance(param, click.Argument):
        return param.name
    flag = next(o for o in param.opts if o.startswith("--"))
    if flag in NOT_KEYWORDS or flag in COMMAND_NOT_KEYWORDS.get(path, {}):
        return None
    return RENAMED.get(flag, flag[2:].replace("-", "_"))


def _default(param: click.Parameter):
    default = param.default
    if default is None or type(default).__name__ == "Sentinel" or default == ():  # not given
        return False if getattr(param, "is_flag", False) and not getattr(param, "secondary_opts", None) else None
    return default


@pytest.mark.parametrize("path", list(COMMANDS), ids=" ".join)
def test_every_option_is_a_keyword_with_the_same_default(path):
    signature = inspect.signature(COMMANDS[path])
    compared = 0
    for param in _command(path).params:
        name = _keyword(param, path)
        if name is None:
            continue
        assert name in signature.parameters, f"turbgen {' '.join(path)} {param.opts[0]} has no keyword {name}"
        api_default = signature.parameters[name].default
        if param.required:  # an argument, or a required option (export --format, --out): a required parameter
            assert api_default is inspect.Parameter.empty, name
        else:
            assert api_default == _default(param), f"{name}: API default {api_default!r}, command {param.default!r}"
        compared += 1
    assert compared > 0


def test_public_signatures_take_no_catch_all():
    for function in (*COMMANDS.values(), turbgen.open_store, turbgen.MannGenerator, turbgen.KaimalGenerator,
                     turbgen.MannGenerator.field, turbgen.KaimalGenerator.field):
        kinds = {p.kind for p in inspect.signature(function).parameters.values()}
        assert inspect.Parameter.VAR_KEYWORD not in kinds and inspect.Parameter.VAR_POSITIONAL not in kinds
