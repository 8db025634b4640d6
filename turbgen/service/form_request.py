"""The run form's values (text, as typed) made into the request body of POST /runs, the equivalent `turbgen` command
and the equivalent Python call; a value that is not of its field's kind is a ParameterError naming the field."""

from __future__ import annotations

import math
import shlex
from collections.abc import Mapping

from turbgen.errors import ParameterError
from turbgen.service.form import MODELS, Field, form_fields
from turbgen.spec.run_inputs import range_positions
from turbgen.theory.ranges import LIMITS


def _number(field: Field, text: str, integer: bool = False):
    try:
        value = int(text) if integer else float(text)
    except ValueError:
        raise ParameterError(f"{field.name}: {text!r} is not {'an integer' if integer else 'a number'}") from None
    if not math.isfinite(value):
        raise ParameterError(f"{field.name}: {text!r} is not a finite number")
    return value


def _numbers(field: Field, text: str, count: int | None, limit: int) -> list[float]:
    items = [v for v in text.replace(" ", ",").split(",") if v]
    if count is not None and len(items) != count:
        raise ParameterError(f"{field.name}: {text!r} needs {count} numbers (u, v, w), comma-separated")
    if len(items) > limit:
        raise ParameterError(f"{field.name}: {len(items)} values is more than the maximum {limit}")
    return [_number(field, v) for v in items]


def parse_value(field: Field, text: str):
    """The value of ``field`` typed as ``text`` (stripped, not empty), as the request body holds it (``gates``: their
    plane positions after the rotor 0; a frozen ``evo``: None)."""
    if field.kind == "evo" and text.lower() in ("frozen", "none"):
        return None
    if field.kind in ("number", "evo"):
        return _number(field, text)
    if field.kind == "integer":
        return _number(field, text, integer=True)
    if field.kind == "flag":
        return text.lower() in ("1", "true", "on", "yes")
    if field.kind == "list3":
        return _numbers(field, text, 3, 3)
    if field.kind == "positions":
        return _numbers(field, text, None, LIMITS["planes"])
    if field.kind == "gates":
        return [0.0, *range_positions(text, field.name, LIMITS["planes"] - 1)]
    if field.kind == "upload":
        return [v.strip() for v in text.split(",") if v.strip()]
    return text


def form_request(model: str, values: Mapping[str, str]) -> dict:
    """``body`` (for POST /runs), ``command`` (uploads as ``FILE``) and ``python`` of the form's ``values`` (field
    name -> text; empty: not given); ParameterError for an unknown model or field (ranges: run_ids.build_run's)."""
    if model not in MODELS:
        raise ParameterError(f"model: {model!r} is not one of {', '.join(MODELS)}")
    fields = {f.name: f for f in form_fields(model)}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        raise ParameterError(f"{unknown[0]}: not a field of the {model} form")
    given = {name: parse_value(fields[name], text.strip()) for name, text in values.items() if text.strip()}
    if "planes" in given and "gates" in given:
        raise ParameterError("gates: give planes or gates, not both")
    body: dict = {"model": model}
    for name, value in given.items():
        key = fields[name].key
        if key.startswith("grid.") or key == "gates":
            body.setdefault("grid", {})["x_m" if key == "gates" else key[5:]] = value
        elif value is not False:
            body[key] = value
    return {"body": body, "command": _command(model, fields, values, given),
            "python": _python(model, fields, values, given)}


def _command(model: str, fields: dict, values: Mapping[str, str], given: dict) -> str:
    words = ["turbgen", model]
    for name, value in given.items():
        field, text = fields[name], values[name].strip()
        if field.kind == "flag":
            words += [field.flag] if value else []
        elif field.kind == "upload":
            words += [w for _ in value for w in (field.flag, "FILE")]
        else:
            words += [field.flag, "frozen" if value is None else ",".join(text.replace(",", " ").split())
                      if field.kind in ("list3", "positions") else text]  # fmt: skip
    return " ".join(shlex.quote(w) if w != "FILE" else w for w in words)


def _python(model: str, fields: dict, values: Mapping[str, str], given: dict) -> str:
    args = []
    for name, value in given.items():
        field = fields[name]
        if field.kind == "upload":
            args.append(f"{name}=[{', '.join(['FILE'] * len(value))}]")
        elif field.kind == "gates":
            args.append(f"gates={values[name].strip()!r}")
        elif field.kind == "flag":
            args += [f"{name}=True"] if value else []
        else:
            args.append(f"{name}={'frozen' if value is None else value!r}".replace("=frozen", "='frozen'"))
    return f"import turbgen\nfield = turbgen.{model}({', '.join(args)})"
