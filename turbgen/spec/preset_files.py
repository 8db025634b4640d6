"""User stability presets from TOML or JSON files (the built-in ones: turbgen.spec.presets).

A file holds ``{"presets": {NAME: {...}}}`` (or NAME -> {...} directly), each entry with an optional ``mann`` table (L,
gamma, evo, factor1, lifetime, ae_ref), an optional ``kaimal`` table (sigma_ratios, length_scales_m, a_yz, lc_m, a_x,
b_x), ``turb_class`` (default "A") and ``source`` (free text). Bad names (built-in, or not a word of letters, digits,
'-', '_'), unknown or missing keys and values outside their ranges raise ParameterError."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from turbgen.errors import ParameterError
from turbgen.spec.config import read_config
from turbgen.spec.presets import BUILTIN_PRESETS, KaimalPreset, MannPreset, StabilityPreset


def _table(data: Mapping, where: str, allowed: set[str], required: set[str] | frozenset[str] = frozenset()) -> dict:
    if not isinstance(data, Mapping):
        raise ParameterError(f"{where} must be a table/object, got {type(data).__name__}")
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise ParameterError(f"{where}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(sorted(allowed))}")
    missing = sorted(required - set(data))
    if missing:
        raise ParameterError(f"{where}: missing {', '.join(missing)}")
    return dict(data)


def preset_from_mapping(name: str, data: Mapping) -> StabilityPreset:
    """The StabilityPreset ``name`` of one entry ``data`` of a user preset file."""
    if not isinstance(name, str) or not name or not name.replace("-", "").replace("_", "").isalnum():
        raise ParameterError(f"preset name {name!r} must be a non-empty word of letters, digits, '-' or '_'")
    if name in BUILTIN_PRESETS:
        raise ParameterError(f"preset name {name!r} is built in; choose another name for a user preset")
    d = _table(data, f"preset {name!r}", {"mann", "kaimal", "turb_class", "source"})
    mann = kaimal = None
    try:
        if "mann" in d:
            m = _table(d["mann"], f"preset {name!r} mann", {"L", "gamma", "evo", "factor1", "lifetime", "ae_ref"},
                       {"L", "gamma", "evo"})
            mann = MannPreset(m["L"], m["gamma"], m["evo"], m.get("factor1", 1.0), m.get("lifetime", "guo"),
                              m.get("ae_ref"))
        if "kaimal" in d:
            keys = {"sigma_ratios", "length_scales_m", "a_yz", "lc_m", "a_x", "b_x"}
            k = _table(d["kaimal"], f"preset {name!r} kaimal", keys, keys)
            kaimal = KaimalPreset(tuple(k["sigma_ratios"]), tuple(k["length_scales_m"]), k["a_yz"], k["lc_m"], k["a_x"],
                                  k["b_x"])
    except TypeError as exc:
        raise ParameterError(f"preset {name!r}: {exc}") from None
    return StabilityPreset(name, mann, kaimal, d.get("turb_class", "A"), str(d.get("source", "user preset")))


def presets_from_mapping(data: Mapping) -> dict[str, StabilityPreset]:
    """{name: StabilityPreset} of a user preset file's content."""
    table = data.get("presets", data) if isinstance(data, Mapping) else data
    if not isinstance(table, Mapping):
        raise ParameterError("user presets must be a table/object NAME -> parameters")
    return {name: preset_from_mapping(name, entry) for name, entry in table.items()}


def load_presets(path: str | Path) -> dict[str, StabilityPreset]:
    """{name: StabilityPreset} of a user preset file (``.json`` is JSON, anything else TOML)."""
    return presets_from_mapping(read_config(path))
