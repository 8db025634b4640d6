"""The keywords of ``turbgen.mann`` / ``turbgen.kaimal`` (the commands' option names, turbgen.spec.run_inputs, with
``planes`` and ``gates``) as run-mapping keys; a run file's keys (``length_scale_m``, ...) come through ``config``."""

from __future__ import annotations

from collections.abc import Mapping

from turbgen.errors import ParameterError
from turbgen.spec.models import declaration, resolve
from turbgen.spec.run_inputs import GRID_OPTIONS, range_positions
from turbgen.theory.ranges import LIMITS

PLANE_KEYWORDS = ("planes", "gates")
# flags: False is "not given", as an option not typed on the command line (a run file's true stays)
_FLAGS = ("rescale", "conditional_mean", "fit")


def _no_files(name: str, value) -> bool:
    """An empty ``constrain`` (the command's repeatable option not given): not given, so a run file's list stays."""
    return name == "constrain" and isinstance(value, (list, tuple)) and not value


def _plane_positions(planes, gates) -> list[float] | None:
    """x [m] from ``planes`` (as given) or ``gates`` (0 added; a sequence or 'start:stop:step' as --gates), or None."""
    if planes is not None and gates is not None:
        raise ParameterError("give `planes` or `gates`, not both")
    if planes is not None:
        return _positions(planes, "`planes`")
    if gates is None:
        return None
    if isinstance(gates, str):
        gates = range_positions(gates, "`gates`", LIMITS["planes"] - 1)
    return [0.0, *_positions(gates, "`gates`")]


def _positions(values, name: str) -> list[float]:
    """``values`` (a number or a flat sequence of numbers) as floats; ParameterError naming ``name`` otherwise."""
    items = [values] if isinstance(values, (int, float)) else values
    try:
        if isinstance(items, (str, bytes)) or any(isinstance(x, (str, bytes, bool)) for x in items):
            raise TypeError
        return [float(x) for x in items]
    except (TypeError, ValueError):
        shown = repr(values) if len(repr(values)) <= 60 else repr(values)[:57] + "..."
        raise ParameterError(f"{name} = {shown} must be a number or a sequence of numbers x [m], e.g. [0, 50]") from None


def run_inputs(model: str, options: Mapping) -> tuple[dict, dict, list[float] | None]:
    """(run-mapping keys given, grid keys given, plane positions [m upstream] or None) of ``model``'s keywords
    ``options`` (option name -> value; None, a flag's False and an empty ``constrain`` are "not given")."""
    aliases = resolve(declaration(model).options, "spec")  # option name -> run key (turbgen.spec.models)
    given, grid = {}, {}
    for name, value in options.items():
        if value is None or name in PLANE_KEYWORDS or (name in _FLAGS and value is False) or _no_files(name, value):
            continue
        if name == "evo" and isinstance(value, str) and value.strip().lower() in ("frozen", "none"):
            value = None  # the evolution time of frozen turbulence
        if name in GRID_OPTIONS:
            grid[GRID_OPTIONS[name]] = value
        else:
            given[aliases[name]] = value
    return given, grid, _plane_positions(options.get("planes"), options.get("gates"))
