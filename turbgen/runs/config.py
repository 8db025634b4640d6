"""Run configuration files (``--config run.toml|json``): read and validate against a JSON Schema.

The schemas live in turbgen/schemas/ (the repository's schemas/ links there), e.g.
mann-run.schema.json. Any problem is a ParameterError naming the file and the offending key.
"""

from __future__ import annotations

import importlib.resources
import json
import tomllib
from pathlib import Path

import jsonschema

from turbgen.errors import ParameterError


def load_schema(name: str) -> dict:
    """The JSON Schema ``turbgen/schemas/<name>.schema.json``."""
    return json.loads(importlib.resources.files("turbgen").joinpath(f"schemas/{name}.schema.json").read_text())


def check_mapping(data, schema_name: str, where: str) -> dict:
    """``data`` if it satisfies the schema, else ParameterError '<where>: <key path>: <message>'."""
    validator = jsonschema.Draft202012Validator(load_schema(schema_name))
    err = jsonschema.exceptions.best_match(validator.iter_errors(data))
    if err is not None:
        at = "/".join(str(q) for q in err.absolute_path) or "(top level)"
        message = err.message
        if err.validator == "pattern":  # say what is expected (the schema's description), not the raw regex
            expected = _description(validator.schema, err.absolute_schema_path)
            message = f"{err.instance!r} is not valid" + (f"; expected {expected}" if expected else "")
        raise ParameterError(f"{where}: {at}: {' '.join(message.split())}")
    return data


def _description(schema: dict, path) -> str | None:
    """The deepest ``description`` on the way to the failing keyword of a schema."""
    found, node = None, schema
    for key in path:
        if isinstance(node, dict) and isinstance(node.get("description"), str):
            found = node["description"]
        try:
            node = node[key]
        except (KeyError, IndexError, TypeError):
            break
    return found


def read_config(path, schema_name: str) -> dict:
    """The mapping in a TOML (``.toml``) or JSON file, validated against ``schema_name``."""
    p = Path(path)
    kind = "TOML" if p.suffix.lower() == ".toml" else "JSON"
    try:
        text = p.read_text()
        data = tomllib.loads(text) if kind == "TOML" else json.loads(text)
    except (OSError, ValueError) as exc:
        raise ParameterError(f"config {p}: cannot read it as {kind} ({' '.join(str(exc).split())})") from None
    return check_mapping(data, schema_name, f"config {p}")
