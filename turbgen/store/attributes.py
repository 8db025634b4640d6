"""Store attributes on the writer's side: the caller's attributes checked and made JSON-ready, and an
existing directory recognised as a turbgen store by its root attributes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import zarr

from turbgen.store import layout


def jsonable(value):
    """``value`` with numpy scalars/arrays and tuples turned into plain JSON types."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.floating):
        return float(str(value))  # shortest repr: float32(3.1) -> 3.1, not 3.0999999046325684
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def looks_like_turbgen_store(path: Path) -> bool:
    """Whether ``path`` opens as a zarr v3 group with turbgen's attributes (complete or not)."""
    layout.silence_consolidated_metadata_warning()
    try:
        return "turbgen_version" in zarr.open_group(str(path), mode="r", zarr_format=3).attrs
    except Exception:  # not a directory, no or garbage zarr.json, an array: not a store of ours
        return False


def check_caller_attrs(attrs: dict) -> dict:
    """Programming errors in the attributes a generator passes (not user input)."""
    missing = [k for k in layout.CALLER_ATTRS if k not in attrs]
    if missing:
        raise ValueError(f"store attrs lack {missing} (required: {list(layout.CALLER_ATTRS)})")
    reserved = [k for k in (*layout.WRITER_ATTRS, layout.FFT_ATTR, layout.RMS_ATTR, layout.MARKER) if k in attrs]
    if reserved:
        raise ValueError(f"store attrs {reserved} are set by the writer, do not pass them")
    out = jsonable(dict(attrs))
    no_unit = [k for k in out["parameters"] if k not in out["units"]]
    if no_unit:
        raise ValueError(f"store attrs 'units' lack a unit for parameters {no_unit} ('1' dimensionless, '' text)")
    json.dumps(out, allow_nan=False)  # raises on values a JSON reader could not load
    return out
