"""User-facing errors (one line each) and the single place where scalar inputs are checked.

Messages name the run's fields in backquotes where they tell the user what to change (e.g. "lower `nt`"); each
front end spells them its own way (the CLI as ``--nt``) and maps the error classes to its exit codes."""

from __future__ import annotations

import math


class TurbgenError(Exception):
    """Base of the errors turbgen reports to its user in one line."""


class ParameterError(TurbgenError, ValueError):
    """A bad input value: one line, naming the value and the allowed range."""


class StoreError(TurbgenError, ValueError):
    """A path that is not a complete, readable turbgen store (or would be overwritten)."""


def one_line(exc: BaseException) -> str:
    """``'ExceptionType: message'`` with the message's whitespace collapsed to one line (a manifest's or a failed
    run's ``error``)."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__

def _is_bool(value) -> bool:
    """True for Python and numpy booleans: numbers to ``float()`` and ``int()``, never a meant value (U=True)."""
    return isinstance(value, bool) or type(value).__name__ in ("bool", "bool_")


def check_finite(name: str, value) -> float:
    """Return ``value`` as float, or raise if it is not a finite number."""
    try:
        number = not _is_bool(value) and math.isfinite(float(value))
    except (TypeError, ValueError):
        number = False
    if not number:
        what = "a bool, not a number" if _is_bool(value) else "not a finite number"
        raise ParameterError(f"{name} = {value!r} is {what}")
    return float(value)


def check_positive(name: str, value) -> float:
    """Return ``value`` as float if it is finite and > 0."""
    v = check_finite(name, value)
    if v <= 0:
        raise ParameterError(f"{name} = {value!r} must be > 0")
    return v


def check_nonnegative(name: str, value) -> float:
    """Return ``value`` as float if it is finite and >= 0."""
    v = check_finite(name, value)
    if v < 0:
        raise ParameterError(f"{name} = {value!r} must be >= 0")
    return v


def _show(value) -> str:
    """A value for a message: floats in short form when exact (1e+12, not 1000000000000.0), else repr."""
    if isinstance(value, float) and math.isfinite(value) and float(f"{value:g}") == value:
        return f"{value:g}"
    return repr(float(value)) if isinstance(value, float) else repr(value)


def check_range(name: str, value, lo: float, hi: float, *, lo_open=False, hi_open=False) -> float:
    """Return ``value`` as float if it lies in the interval from ``lo`` to ``hi``."""
    v = check_finite(name, value)
    bad_lo = v <= lo if lo_open else v < lo
    bad_hi = v >= hi if hi_open else v > hi
    if bad_lo or bad_hi:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        raise ParameterError(f"{name} = {_show(value)} is outside the allowed range {left}{lo:g}, {hi:g}{right}")
    return v


def check_int(name: str, value, lo: int, hi: int | None = None) -> int:
    """Return ``value`` as int if it is an integer >= lo (and <= hi when given)."""
    try:
        iv = int(value)
        # a Python int is exact at any size (float() would round it and call 2**63 "not an integer")
        ok = not _is_bool(value) and (isinstance(value, int) or float(value) == iv)
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        what = "a bool, not an integer" if _is_bool(value) else "not an integer"
        raise ParameterError(f"{name} = {value!r} is {what}")
    if iv < lo or (hi is not None and iv > hi):
        upper = f", {hi}]" if hi is not None else ", ∞)"
        raise ParameterError(f"{name} = {value!r} is outside the allowed range [{lo}{upper}")
    return iv


def check_choice(name: str, value, choices) -> str:
    """Return ``value`` if it is one of ``choices``."""
    if value not in choices:
        raise ParameterError(f"{name} = {value!r} is not one of {', '.join(map(str, choices))}")
    return value


def check_instances(**named) -> None:
    """TypeError naming the first argument ``name=(value, cls)`` whose value is not a ``cls`` (e.g. a dict given
    where a turbgen.MannParams is expected)."""
    for name, (value, cls) in named.items():
        if not isinstance(value, cls):
            raise TypeError(f"{name} must be a turbgen.{cls.__name__}, not {type(value).__name__}")
