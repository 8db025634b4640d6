"""Service run requests and their ids.

A run id is the first 24 hex digits of the SHA-256 of the canonical JSON of (model, run parameters,
grid, turbgen version); the seed is one of the parameters. Identical requests give the same id.
"""

from __future__ import annotations

import hashlib
import json
import re

from turbgen.version import __version__
from turbgen.errors import ParameterError
from turbgen.spec.config import check_mapping
from turbgen.spec.constraints import CONSTRAINT_KEYS
from turbgen.store.layout import grid_to_attrs

_ID = re.compile(r"^[0-9a-f]{24}$")


def build_run(body) -> tuple[str, object]:
    """(model, MannRun | KaimalRun) from a request body: {"model": ..., "preset": ..., <run config keys>}.

    The run config keys are those of ``turbgen mann|kaimal --config`` (schemas/<model>-run.schema.json);
    ``preset`` sets the stability keys as ``--preset`` does (at the body's U), given keys override it.

    Parameters
    ----------
    body : dict
        The request's JSON object; ``model`` defaults to "mann".

    Returns
    -------
    tuple of (str, MannRun or KaimalRun)
        The model name and the run.

    Raises
    ------
    ParameterError
        Naming the bad field: not an object, unknown model or preset, schema violation or a value out of range.
    """
    if not isinstance(body, dict):
        raise ParameterError("request body: expected a JSON object with the run config")
    body = dict(body)
    model = body.pop("model", "mann")
    entry = _model(model)
    preset = body.pop("preset", None)
    check_mapping(body, f"{model}-run", "run config")
    refused = [key for key in CONSTRAINT_KEYS if key in body]
    if refused:  # the server never opens paths a client names; conditioning is a local run (CLI, API, sweep)
        raise ParameterError(f"{', '.join(refused)}: constrained fields are not taken by the service (it does not "
                             "read files named by a client); make them with `turbgen mann --constrain` or a sweep")
    if preset is not None:
        from turbgen.spec.preset_runs import run_keys

        if not isinstance(preset, str):
            raise ParameterError("preset: expected a preset name (string)")
        U = body.get("U_m_s")
        if isinstance(U, bool) or not isinstance(U, (int, float)):  # a bad U is reported by from_mapping below
            U = entry.spec.from_mapping({}).U_m_s
        body = {**run_keys(model, preset, U), **body}
    return model, entry.spec.from_mapping(body)


def _model(name):
    """The registry entry of ``name`` (ParameterError naming the field otherwise)."""
    from turbgen.runs.models import MODELS

    if name not in MODELS:
        raise ParameterError(f"model: {name!r} is not one of {', '.join(MODELS)}")
    return MODELS[name]


def canonical_mapping(run) -> dict:
    """The run mapping that rebuilds ``run`` exactly: its parameters (seed included) and its grid.

    Parameters
    ----------
    run : MannRun or KaimalRun
        The run.

    Returns
    -------
    dict
        ``run.parameters()`` plus ``grid`` (store attribute form).
    """
    return {**run.parameters(), "grid": grid_to_attrs(run.grid)}


def run_from_canonical(model: str, mapping: dict):
    """Inverse of :func:`canonical_mapping` (used to re-queue runs after a restart).

    Parameters
    ----------
    model : str
        Model name.
    mapping : dict
        A canonical mapping.

    Returns
    -------
    MannRun or KaimalRun

    Raises
    ------
    ParameterError
        For an unknown model, key or a value out of range.
    """
    return _model(model).spec.from_mapping(mapping)


def run_id(model: str, mapping: dict) -> str:
    """24 hex digits of SHA-256 over the canonical JSON of model, mapping and turbgen version.

    Parameters
    ----------
    model : str
        Model name.
    mapping : dict
        The canonical run mapping (:func:`canonical_mapping`).

    Returns
    -------
    str
    """
    text = json.dumps({"model": model, "run": mapping, "turbgen": __version__}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def valid_id(text: str) -> bool:
    """True for a well-formed run id (anything else is answered 404 before touching the disk).

    Parameters
    ----------
    text : str
        Candidate id.

    Returns
    -------
    bool
    """
    return bool(_ID.match(text))
