"""The run of ``turbgen.mann`` / ``turbgen.kaimal`` and of their commands from the user's options (the commands' option
names, ``planes`` and ``gates``), a run file and a preset (turbgen.spec.run_inputs): light, so the commands refuse a
bad value before they import the run (zarr, numba)."""

from __future__ import annotations

import os
from collections.abc import Mapping
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
from turbgen.spec.run_inputs import GRID_OPTIONS, merge_run_inputs, range_positions
from turbgen.theory.ranges import LIMITS

PathLike = str | os.PathLike
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
