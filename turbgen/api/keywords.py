"""The keywords of ``turbgen.mann`` / ``turbgen.kaimal`` as run-mapping keys, data-driven.

Accepted, for a model: the command's option names (turbgen.spec.run_inputs: ``L``, ``gamma``, ``evo``, ``U``, ``nt``,
``dt``, ``ny``, ``nz``, ``dy``, ``dz``, ...), ``planes`` and ``gates``, and every key of the model's run schema
(turbgen/schemas/<model>-run.schema.json) and of its ``grid`` table under its own name. A key added to a run schema is
therefore a keyword at once; anything else is refused, naming the keywords allowed.
"""

from __future__ import annotations

from collections.abc import Mapping

from turbgen.errors import ParameterError
from turbgen.spec.config import load_schema
from turbgen.spec.models import declaration, resolve
from turbgen.spec.run_inputs import GRID_OPTIONS, range_positions
from turbgen.theory.ranges import LIMITS

PLANE_KEYWORDS = ("planes", "gates")


def _aliases(model: str) -> dict:
    """Option name -> run key of ``model`` (its declared ``options``, turbgen.spec.models)."""
    return resolve(declaration(model).options, "spec")


def schema_keys(model: str) -> tuple[frozenset, frozenset]:
    """The run keys and the grid keys of ``model``'s run schema (``grid`` itself excluded)."""
    props = load_schema(declaration(model).schema)["properties"]
    return frozenset(props) - {"grid"}, frozenset(props["grid"]["properties"])


def allowed_keywords(model: str) -> list[str]:
    """Every keyword ``turbgen.<model>(...)`` takes for the run, sorted: option names first, then schema keys."""
    run_keys, grid_keys = schema_keys(model)
    options = [*_aliases(model), *GRID_OPTIONS, *PLANE_KEYWORDS]
    return options + sorted((run_keys | grid_keys) - set(options))


def _evo_value(value):
    """'frozen' (or 'none') -> None, the evolution time of frozen turbulence; other values as given."""
    if isinstance(value, str) and value.strip().lower() in ("frozen", "none"):
        return None
    return value


def _plane_positions(planes, gates) -> list[float] | None:
    """x [m] from ``planes`` (as given) or ``gates`` (the rotor plane 0 added; a sequence, or 'start:stop:step' as
    the CLI's --gates), or None."""
    if planes is not None and gates is not None:
        raise ParameterError("give `planes` or `gates`, not both")
    if planes is not None:
        return [float(x) for x in ([planes] if isinstance(planes, (int, float)) else planes)]
    if gates is None:
        return None
    if isinstance(gates, str):
        gates = range_positions(gates, "`gates`", LIMITS["planes"] - 1)
    return [0.0, *(float(x) for x in gates)]


def run_inputs(model: str, options: Mapping) -> tuple[dict, dict, list[float] | None]:
    """Split keyword values into (run keys, grid keys, plane positions [m] or None); None values are "not given".

    Parameters
    ----------
    model : str
        "mann" or "kaimal".
    options : Mapping
        Keyword -> value, as passed to ``turbgen.mann`` / ``turbgen.kaimal``.

    Returns
    -------
    tuple
        (run-mapping keys given, grid-table keys given, plane positions [m upstream] or None).

    Raises
    ------
    ParameterError
        For keywords the model does not take (naming them and the allowed ones).
    """
    aliases = _aliases(model)
    run_keys, grid_keys = schema_keys(model)
    unknown = sorted(set(options) - set(aliases) - set(GRID_OPTIONS) - set(PLANE_KEYWORDS) - run_keys - grid_keys)
    if unknown:
        raise ParameterError(f"turbgen.{model}() got unknown keyword(s) {', '.join(unknown)}; "
                             f"allowed: {', '.join(allowed_keywords(model))}")  # fmt: skip
    given, grid = {}, {}
    for name, value in options.items():
        if value is None or name in PLANE_KEYWORDS:
            continue
        if name == "evo":
            value = _evo_value(value)
        table, key = (grid, GRID_OPTIONS.get(name, name)) if name in GRID_OPTIONS or name in grid_keys else \
            (given, aliases.get(name, name))
        if key in table:
            raise ParameterError(f"turbgen.{model}() got `{key}` twice (as {name} and under another name)")
        table[key] = value
    return given, grid, _plane_positions(options.get("planes"), options.get("gates"))
