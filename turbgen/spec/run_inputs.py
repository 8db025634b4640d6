"""How a run's inputs become one run mapping for every front end: run file < preset < the user's options.

What none of them gives takes turbgen.spec.defaults (in the model's from_mapping). The option names
are the commands' (``turbgen mann --L 49`` is ``turbgen.mann(L=49)``); any key of the model's run
schema is accepted under its own name too, so a key added to a schema needs no new option. The front ends' run
mappings (options -> run) are turbgen.spec.run_mapping."""

from __future__ import annotations

from collections.abc import Callable, Mapping

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

    from turbgen.errors import ParameterError

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

