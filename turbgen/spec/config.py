"""The one reader of TOML/JSON files: run files (``--config``), sweep files and preset files.

Files are validated against a JSON Schema of turbgen/schemas/ (e.g. mann-run.schema.json); any
problem is a ParameterError naming the file and the offending key."""

from __future__ import annotations

import importlib.resources
import json
import tomllib
from pathlib import Path

import jsonschema

from turbgen.errors import ParameterError
from turbgen.input_files import CONFIG, read_input

MAX_NESTING = 64  # levels of tables/arrays in a TOML/JSON file: turbgen's own files need 4


def load_schema(name: str) -> dict:
    """The JSON Schema ``turbgen/schemas/<name>.schema.json`` (FileNotFoundError if there is none)."""
    return json.loads(importlib.resources.files("turbgen").joinpath(f"schemas/{name}.schema.json").read_text())


def check_mapping(data, schema_name: str, where: str) -> dict:
    """``data`` if it satisfies the schema ``schema_name``, else ParameterError '<where>: <key path>: <message>' of
    the best-matching error (a failed ``pattern``: the schema's description, not the regex)."""
    validator = jsonschema.Draft202012Validator(load_schema(schema_name))
    err = jsonschema.exceptions.best_match(validator.iter_errors(data))
    if err is not None:
        at = "/".join(str(q) for q in err.absolute_path) or "(top level)"
        message = err.message
        if err.validator == "pattern":  # say what is expected (the schema's description), not the raw regex
            expected = _description(validator.schema, err.absolute_schema_path)
            message = f"{err.instance!r} is not valid" + (f"; expected {expected}" if expected else "")
        message = message.replace(repr(err.instance), _short(err.instance))
        if err.validator == "maxItems":
            message += f" (at most {err.validator_value})"
        raise ParameterError(f"{where}: {at}: {' '.join(message.split())}")
    return data


def _short(instance, limit: int = 80) -> str:
    """``repr(instance)``, or for a long one what it is ("a list of 1001 items"), so a message stays one short line."""
    text = repr(instance)
    if len(text) <= limit:
        return text
    if isinstance(instance, (list, tuple)):
        return f"a list of {len(instance)} items"
    if isinstance(instance, dict):
        return f"an object of {len(instance)} keys ({', '.join(map(repr, list(instance)[:5]))}, ...)"
    return text[:limit] + "..."


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


def read_config(path, schema_name: str | None = None) -> dict:
    """The top-level table of a TOML or JSON (``.json``) file, validated against ``schema_name`` if given.
    ParameterError if the file cannot be read, is not a regular file or too large (turbgen.input_files), is not
    valid TOML/JSON or nested deeper than MAX_NESTING, fails the schema, or (without one) holds no table."""
    p = Path(path)
    data = parse_document(read_input(p, CONFIG), "JSON" if p.suffix.lower() == ".json" else "TOML", f"config {p}")
    if schema_name is not None:
        return check_mapping(data, schema_name, f"config {p}")
    if not isinstance(data, dict):
        raise ParameterError(f"config {p}: must hold a table/object at the top level")
    return data


def parse_document(text: bytes, kind: str, where: str):
    """The value of the JSON or TOML (``kind``) document ``text``; ParameterError naming ``where`` for invalid text
    (or not UTF-8) or nesting deeper than MAX_NESTING (a parser's RecursionError included)."""
    nested = ParameterError(f"{where}: nested deeper than {MAX_NESTING} levels of tables/arrays")
    try:
        data = json.loads(text, parse_constant=_refuse_constant) if kind == "JSON" else tomllib.loads(text.decode())
    except RecursionError:
        raise nested from None
    except (ValueError, UnicodeDecodeError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ParameterError(f"{where}: not valid {kind} ({first})") from None
    if nested_deeper_than(data, MAX_NESTING):
        raise nested
    return data


def _refuse_constant(name: str):
    """json.loads's hook for NaN and +-Infinity (not JSON): refused, not taken for a missing value."""
    raise ValueError(f"{name} is not a JSON number (write null for a missing value)")


def nested_deeper_than(data, limit: int) -> bool:
    """Whether ``data`` nests dicts/lists more than ``limit`` levels, found without recursion."""
    stack = [(data, 1)] if isinstance(data, (dict, list)) else []
    while stack:  # containers only: a long list of numbers is scanned once, not pushed value by value
        value, depth = stack.pop()
        if depth > limit:
            return True
        stack.extend((v, depth + 1) for v in (value.values() if isinstance(value, dict) else value)
                     if isinstance(v, (dict, list)))
    return False
