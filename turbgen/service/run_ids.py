"""Service run requests and their ids.

A run id is the first 24 hex digits of the SHA-256 of the canonical JSON of (model, run parameters with the seed,
grid, constraint keys naming uploads by content digest, turbgen version): identical requests give the same id."""

from __future__ import annotations

import hashlib
import json
import re
from typing import cast

from turbgen.version import __version__
from turbgen.errors import ParameterError
from turbgen.spec.config import check_mapping
from turbgen.spec.constraints import CONSTRAINT_KEYS, split_constraint_keys
from turbgen.store.layout import grid_to_attrs

_ID = re.compile(r"^[0-9a-f]{24}$")
SERVICE_KEYS = (*CONSTRAINT_KEYS, "energy_from_data")  # the constraint keys of a recorded request
ENERGY_KEYS = ("ae", "sigma_u_m_s", "ti", "turb_class")  # a constrained request with none: ae from the data
# the run keys a replay (``fit``) sets from the data unless the request gives them (turbgen.runs.replay)
FIT_SETS = ("ae", "ae_from", "length_scale_m", "gamma", "sigma_u_m_s", "ti", "U_m_s", "evo_time_s")


def build_run(body) -> tuple[str, object, dict]:
    """(model, MannRun | KaimalRun, constraint keys) from a request body {"model", "preset", ``--config`` keys}
    (``constrain`` names uploads by id, not files). ParameterError naming the bad field."""
    if not isinstance(body, dict):
        raise ParameterError("request body: expected a JSON object with the run config")
    body = dict(body)
    model = body.pop("model", "mann")
    entry = _model(model)
    preset = body.pop("preset", None)
    check_mapping(body, f"{model}-run", "run config")
    if isinstance(body.get("spectrum"), str):  # a path would read the server's files
        raise ParameterError("spectrum: the service takes the table itself ({f_hz, S_u, S_v, S_w}), not a file name")
    constraints = constraint_keys({key: body.pop(key) for key in CONSTRAINT_KEYS if key in body})
    if constraints and model != "mann":
        raise ParameterError(f"constrain: the service conditions Mann runs only, not {model}")
    if "fit" in constraints:
        if preset is not None:
            raise ParameterError(f"preset with fit: the fit sets L, gamma and the energy level of {preset!r} from the "
                                 "data; drop the preset, or drop fit")
        constraints["fit"] = {"given": sorted(k for k in FIT_SETS if k in body)}  # the rest the worker fits
    if preset is not None:
        from turbgen.spec.preset_runs import run_keys

        if not isinstance(preset, str):
            raise ParameterError("preset: expected a preset name (string)")
        U = body.get("U_m_s")
        if isinstance(U, bool) or not isinstance(U, (int, float)):  # a bad U is reported by from_mapping below
            U = entry.spec.from_mapping({}).U_m_s
        body = {**run_keys(model, preset, U), **body}
    if constraints and "fit" not in constraints and not any(key in body for key in ENERGY_KEYS):
        constraints["energy_from_data"] = True  # as `turbgen mann --constrain`: ae estimated from the data (worker)
    return model, entry.spec.from_mapping(body), constraints


def constraint_keys(mapping: dict) -> dict:
    """The constraint keys of a run request in canonical form ({} without constraints): ``constrain`` (upload ids),
    ``noise_m_s`` when given, ``conditional_mean`` and ``energy_from_data`` when true, ``fit`` ({"given": the
    :data:`FIT_SETS` keys the request gives}) for a replay."""
    request = split_constraint_keys({k: v for k, v in mapping.items() if k != "energy_from_data"})[1]
    fit = mapping.get("fit")  # true in a request, {"given": [...]} as recorded
    if request is None:
        return {}
    for n, cid in enumerate(request.files):
        if not isinstance(cid, str) or not valid_id(cid):
            raise ParameterError(f"constrain[{n}] = {cid!r}: the service takes the id of uploaded measurements "
                                 "(POST /constraints), not a file")
    return {"constrain": list(request.files), **({} if request.noise_m_s is None else {"noise_m_s": request.noise_m_s}),
            **({"conditional_mean": True} if request.conditional_mean else {}),
            **({"energy_from_data": True} if mapping.get("energy_from_data") else {}),
            **({"fit": {"given": sorted(fit["given"] if isinstance(fit, dict) else ())}} if request.fit else {})}


def replay_mapping(run, constraints: dict) -> dict | None:
    """The run mapping of a replay request that the worker's fit completes (turbgen.runs.replay), None for others."""
    if "fit" not in constraints:
        return None
    return {k: v for k, v in canonical_mapping(run, constraints).items() if k not in SERVICE_KEYS}


def check_replay(run, constraints: dict, files: list) -> tuple:
    """The fit of a replay (turbgen.runs.replay.fitted_inputs), handed to the worker; ParameterError where ``turbgen
    mann --fit`` refuses the replay: the keys its fit sets (Gamma is held for a lidar record: given, it is the value
    held), and the fit's own refusals (a flagged fit, say). A run re-queued after a restart is fitted again."""
    from turbgen.runs.constrain import load_constraints
    from turbgen.runs.replay import check_fit_options, fitted_inputs
    from turbgen.spec.mann import OPTIONS
    from turbgen.virtual_lidar.dataset import LidarData

    data, mapping = load_constraints(files), cast(dict, replay_mapping(run, constraints))
    given = {name: True for name, key in OPTIONS.items() if key in constraints["fit"]["given"]}
    check_fit_options(given, prefix="", lidar=any(isinstance(c, LidarData) for c in data))
    return fitted_inputs(mapping, data, evo_typed="evo_time_s" in mapping)


def _model(name):
    """The registry entry of ``name`` (ParameterError naming the field otherwise)."""
    from turbgen.runs.models import MODELS

    if name not in MODELS:
        raise ParameterError(f"model: {name!r} is not one of {', '.join(MODELS)}")
    return MODELS[name]


def canonical_mapping(run, constraints: dict | None = None) -> dict:
    """The run mapping that rebuilds ``run`` exactly: its parameters (seed included), ``grid`` and ``constraints``."""
    constraints = constraints or {}
    drop: tuple = ("ae", "ae_from") if constraints.get("energy_from_data") else ()  # the worker estimates it
    if "fit" in constraints:  # a replay: the worker fits the keys not given
        drop = tuple(k for k in FIT_SETS if k not in constraints["fit"]["given"])
    return {**{k: v for k, v in run.parameters().items() if k not in drop}, "grid": grid_to_attrs(run.grid),
            **constraints}


def run_from_canonical(model: str, mapping: dict):
    """Inverse of :func:`canonical_mapping`: (run, constraint keys), to re-queue runs after a restart."""
    constraints = constraint_keys({key: mapping[key] for key in SERVICE_KEYS if key in mapping})
    rest = {key: value for key, value in mapping.items() if key not in SERVICE_KEYS}
    return _model(model).spec.from_mapping(rest), constraints


def run_id(model: str, mapping: dict) -> str:
    """24 hex digits of SHA-256 over the canonical JSON of ``model``, the canonical ``mapping`` and turbgen version."""
    text = json.dumps({"model": model, "run": mapping, "turbgen": __version__}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def valid_id(text: str) -> bool:
    """True for a well-formed run id (anything else is answered 404 before touching the disk)."""
    return bool(_ID.match(text))
