"""How a run's inputs become one run mapping for every front end: run file < preset < the user's options.

What none of them gives takes turbgen.spec.defaults (in the model's from_mapping). The option names
are the commands' (``turbgen mann --L 49`` is ``turbgen.mann(L=49)``); any key of the model's run
schema is accepted under its own name too, so a key added to a schema needs no new option. Light on purpose: the
commands refuse a bad value before they import the run (zarr, numba)."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path

from turbgen.errors import ParameterError
from turbgen.spec.config import check_mapping, read_config
from turbgen.spec.constraints import ConstraintRequest, resolve_constraint_paths, split_constraint_keys
from turbgen.spec.defaults import KAIMAL_DEFAULTS
from turbgen.spec.kaimal import REPLACES as KAIMAL_REPLACES
from turbgen.spec.kaimal import KaimalRun
from turbgen.spec.mann import ENERGY_KEYS as MANN_ENERGY_KEYS
from turbgen.spec.mann import REPLACES as MANN_REPLACES
from turbgen.spec.models import declaration, resolve
from turbgen.spec.preset_files import load_presets
from turbgen.spec.preset_runs import kaimal_run_keys, mann_run_keys
from turbgen.theory.ranges import LIMITS

PathLike = str | os.PathLike
# option name -> key of the run mapping's grid table
GRID_OPTIONS = {"nt": "nt", "dt": "dt_s", "ny": "ny", "nz": "nz", "dy": "dy_m", "dz": "dz_m"}


def merge_run_inputs(
    file_mapping: Mapping | None,
    given: Mapping,
    grid_given: Mapping,
    *,
    preset_keys: Callable[[Mapping, Mapping], Mapping] | None = None,
    replaces: Mapping[str, tuple] | None = None,
    x_m=None,
) -> dict:
    """The run mapping of one run, with its ``grid`` table: the run file's keys, then the preset's, then the given ones;
    ``preset_keys(file mapping, given)``: the preset's run keys (None without a preset); ``replaces``: given key -> keys
    it removes from the run file and the preset (one energy level, one source); ``x_m``: plane positions [m upstream]
    (None keeps the file's or the default)."""
    mapping = dict(file_mapping or {})
    grid = dict(mapping.pop("grid", {}))
    layers = [mapping, dict(preset_keys(mapping, given)) if preset_keys else {}]
    for key in given:
        for layer in layers:
            for gone in (replaces or {}).get(key, ()):
                layer.pop(gone, None)
    grid.update(grid_given)
    if x_m is not None:
        grid["x_m"] = list(x_m)
    return {**layers[0], **layers[1], **given, "grid": grid}


def range_positions(text: str, name: str, limit: int) -> list[float]:
    """'start:stop:step' [m] -> start, start + step, ... <= stop (1e-9 relative tolerance), rounded to 9 decimals
    as the CLI's ``--gates``. ParameterError naming ``name`` for a malformed text, step <= 0, stop < start, a
    non-finite number or more than ``limit`` values."""
    import math

    try:
        start, stop, step = (float(p) for p in text.split(":"))
    except ValueError:
        raise ParameterError(f"{name} = {text!r} is not start:stop:step (three numbers)") from None
    if not (step > 0 and stop >= start and all(map(math.isfinite, (start, stop, step)))):
        raise ParameterError(f"{name} = {text!r} needs finite numbers, step > 0 and stop >= start")
    n = int(math.floor((stop - start) / step * (1 + 1e-9) + 1e-9)) + 1
    if n > limit:
        raise ParameterError(f"{name} = {text!r} gives {n} values, more than the maximum {limit}")
    return [round(start + i * step, 9) for i in range(n)]


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


def _file_mapping(config, schema: str) -> dict | None:
    """A run file's content (a path to TOML/JSON) or a mapping of the same keys, checked against ``schema``."""
    if config is None:
        return None
    if isinstance(config, Mapping):
        return dict(check_mapping(dict(config), schema, "`config`"))
    return resolve_constraint_paths(read_config(config, schema), Path(config).parent)


def _presets(preset, presets_file):
    if presets_file is not None and preset is None:
        raise ParameterError("`presets_file` needs `preset`")
    return load_presets(presets_file) if presets_file is not None else None


def mann_run_mapping(options: Mapping, config: PathLike | Mapping | None = None, preset: str | None = None,
                     presets_file: PathLike | None = None) -> tuple[dict, ConstraintRequest | None]:
    """The run mapping of ``turbgen.mann`` and ``turbgen mann`` (run file < preset < ``options``, option name ->
    value or None) and the ConstraintRequest (None: unconstrained). ParameterError for two energy levels,
    ``presets_file`` without ``preset``, a bad run file or value."""
    given, grid, x_m = run_inputs("mann", options)
    energy = [key for key in MANN_ENERGY_KEYS if key in given]
    if len(energy) > 1:
        raise ParameterError(f"give one of `ae`, `sigma_u`, `ti` (got {', '.join(energy)})")
    user = _presets(preset, presets_file)
    keys = None if preset is None else (lambda mapping, typed: mann_run_keys(preset, user=user))
    return split_constraint_keys(merge_run_inputs(_file_mapping(config, "mann-run"), given, grid, preset_keys=keys,
                                                  replaces=MANN_REPLACES, x_m=x_m))  # fmt: skip


def kaimal_run(options: Mapping, config: PathLike | Mapping | None = None, preset: str | None = None,
               presets_file: PathLike | None = None) -> tuple[KaimalRun, dict]:
    """The KaimalRun of ``turbgen.kaimal`` and ``turbgen kaimal`` (run file < preset < ``options``) and the preset's
    keys resolved at its U and class ({} without a preset). ParameterError as :func:`mann_run_mapping`."""
    if options.get("sigma") is not None and options.get("spectrum") is not None:
        raise ParameterError("`sigma` (--sigma) with `spectrum`: the user spectrum sets sigma_u, sigma_v, sigma_w "
                             "(its integral over the run's lines); scale the spectrum instead")
    given, grid, x_m = run_inputs("kaimal", options)
    user = _presets(preset, presets_file)
    resolved: dict = {}

    def keys(mapping, typed):  # the preset's sigmas follow the run's U and a given class
        U_m_s = typed.get("U_m_s", mapping.get("U_m_s", KAIMAL_DEFAULTS["U_m_s"]))
        resolved.update(kaimal_run_keys(preset, U_m_s, user=user, turb_class=typed.get("turb_class")))
        return dict(resolved)

    run = KaimalRun.from_mapping(merge_run_inputs(_file_mapping(config, "kaimal-run"), given, grid,
                                                  preset_keys=None if preset is None else keys,
                                                  replaces=KAIMAL_REPLACES, x_m=x_m))  # fmt: skip
    return run, resolved
