"""Parsers for list-valued CLI options ("0,50,100", "50:170:13.3", "1-21")."""

from __future__ import annotations

import math

import click


def parse_floats(text: str, name: str) -> list[float]:
    """'a,b,c' -> [a, b, c] (finite floats)."""
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"{text!r} is not a comma-separated list of numbers", param_hint=name) from None
    if not values or not all(math.isfinite(v) for v in values):
        raise click.BadParameter(f"{text!r} must hold finite numbers", param_hint=name)
    return values


def parse_range(text: str, name: str) -> list[float]:
    """'start:stop:step' -> start, start+step, ... <= stop (inclusive, 1e-9 relative tolerance)."""
    parts = text.split(":")
    try:
        start, stop, step = (float(p) for p in parts)
    except ValueError:
        raise click.BadParameter(f"{text!r} is not start:stop:step", param_hint=name) from None
    if not (step > 0 and stop >= start and all(map(math.isfinite, (start, stop, step)))):
        raise click.BadParameter(f"{text!r} needs step > 0 and stop >= start", param_hint=name)
    n = int(math.floor((stop - start) / step * (1 + 1e-9) + 1e-9)) + 1
    return [round(start + i * step, 9) for i in range(n)]


def parse_ints(text: str, name: str) -> list[int]:
    """'1-21' or '1,4,7' or '1-3,9' -> sorted unique ints."""
    out: set[int] = set()
    try:
        for part in text.split(","):
            part = part.strip()
            if not part:
                continue
            if "-" in part[1:]:
                lo, hi = part.split("-", 1) if not part.startswith("-") else (part, part)
                lo_i, hi_i = int(lo), int(hi)
                if hi_i < lo_i:
                    raise ValueError
                out.update(range(lo_i, hi_i + 1))
            else:
                out.add(int(part))
    except ValueError:
        raise click.BadParameter(f"{text!r} is not a list of integers or ranges like 1-21", param_hint=name) from None
    if not out:
        raise click.BadParameter(f"{text!r} holds no integer", param_hint=name)
    return sorted(out)


def plane_positions(planes: list[float] | None, gates: list[float] | None) -> list[float] | None:
    """x positions [m] from --planes (taken as given) or --gates (the rotor plane 0 added); None if neither."""
    if planes is not None and gates is not None:
        raise click.UsageError("give --planes or --gates, not both")
    if planes is not None:
        return list(planes)
    if gates is not None:
        return [0.0, *gates]
    return None
