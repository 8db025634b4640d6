"""A sweep plan from a TOML or JSON file or mapping (``turbgen/schemas/sweep.schema.json``), and seed lists."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from turbgen.errors import ParameterError
from turbgen.runs.models import MODELS
from turbgen.spec.config import check_mapping, read_config
from turbgen.spec.constraints import CONSTRAINT_KEYS, resolve_constraint_paths, split_constraint_keys
from turbgen.spec.preset_files import load_presets, presets_from_mapping
from turbgen.spec.presets import StabilityPreset
from turbgen.sweep.plan import SweepPlan, make_plan
from turbgen.theory import ranges


def parse_seeds(value) -> list[int]:
    """Sorted seeds of a list of ints or a text like '1-21' / '1-3,9' (inclusive, merged); ParameterError for a
    bad entry, a backward range or too many seeds."""
    if not isinstance(value, str):
        ranges.check_count("seeds", len(value))
        return sorted(value)
    try:
        return ranges.parse_ints(value)
    except ParameterError as exc:
        raise ParameterError(f"seeds = {value!r}: {exc}") from None


def plan_from_mapping(data: Mapping, *, base_dir: str | Path = ".", **overrides) -> SweepPlan:
    """Plan from a sweep mapping; non-None ``overrides`` (out, validate, workers, scheduler, chunk_t) replace its
    values (a scheduler drops the file's workers); paths relative to ``base_dir``. ParameterError as :func:`make_plan`,
    and for a schema violation, a user preset defined twice, or no ``out``."""
    check_mapping(data, "sweep", "sweep definition")
    unknown = [m for m in data["models"] if m not in MODELS]  # the schema takes any name: the registry's models
    if unknown:
        raise ParameterError(f"sweep definition: models/{data['models'].index(unknown[0])}: {unknown[0]!r} is not one "
                             f"of {', '.join(MODELS)}")
    base = Path(base_dir)
    user: dict[str, StabilityPreset] = {}
    if "preset_file" in data:
        user.update(load_presets(base / data["preset_file"]))
    if "user_presets" in data:
        inline = presets_from_mapping(data["user_presets"])
        clash = sorted(set(inline) & set(user))
        if clash:
            raise ParameterError(f"user preset(s) {', '.join(clash)} defined both inline and in preset_file")
        user.update(inline)
    constrain = {key: data[key] for key in CONSTRAINT_KEYS if key in data}  # paths relative to the file
    kw = dict(
        out=base / data["out"] if "out" in data else None,
        models=data["models"],
        presets=data["presets"],
        speeds=data["speeds"],
        seeds=parse_seeds(data["seeds"]),
        grid=data.get("grid"),
        model_grid={m: data[m] for m in MODELS if m in data},
        validate=data.get("validate", False),
        chunk_t=data.get("chunks"),
        workers=data.get("workers"),
        scheduler=data.get("scheduler"),
        user_presets=user,
        lidar=data.get("lidar"),
        constraints=split_constraint_keys(resolve_constraint_paths(constrain, base))[1],
        spectrum=str(base / data["spectrum"]) if "spectrum" in data else None,
    )
    kw.update({k: v for k, v in overrides.items() if v is not None})
    if kw["out"] is None:
        raise ParameterError("no output directory: give `out` in the sweep file or on the command line")
    if overrides.get("scheduler"):
        kw["workers"] = overrides.get("workers")
    return make_plan(**kw)


def plan_from_file(path: str | Path, **overrides) -> SweepPlan:
    """Plan from a TOML or JSON sweep file (:func:`plan_from_mapping`, paths relative to the file)."""
    data = read_config(path, "sweep")
    return plan_from_mapping(data, base_dir=Path(path).parent, **overrides)
