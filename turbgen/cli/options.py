"""Parsers for list-valued CLI options ("0,50,100", "50:170:13.3", "1-21") and helpers shared by commands."""

from __future__ import annotations

import functools
import math

import click

from turbgen.errors import ParameterError
from turbgen.theory import ranges
from turbgen.theory.ranges import LIMITS, RANGES, count_text


class FiniteFloatRange(click.FloatRange):
    """click.FloatRange that also refuses nan (every comparison with nan is false, so FloatRange lets it through)."""

    def convert(self, value, param, ctx):
        v = super().convert(value, param, ctx)
        if not math.isfinite(v):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return v


def evo_seconds(ctx, param, value):
    """Callback of a model's --evo: seconds, or 'frozen' / 'none' (frozen turbulence, no evolution lifetime) -> None."""
    if value is None or value.strip().lower() in ("frozen", "none"):
        return None
    try:
        return float(value)
    except ValueError:
        raise click.BadParameter(f"{value!r} is not a number of seconds or 'frozen'") from None


def stacked(options: list):
    """One decorator applying click ``options`` in order (the first listed first in --help)."""
    return lambda f: functools.reduce(lambda g, option: option(g), reversed(options), f)


def plot_figure(figsize=None, **subplots):
    """A matplotlib Figure of ``figsize`` [in] and its axes (``Figure.subplots(**subplots)``): no pyplot, no display."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots(**subplots)


def save_plot(fig, path, dpi: int) -> None:
    """Lay out ``fig`` and write it to the --plot ``path`` as PNG (atomically: never a partial file)."""
    from turbgen.store.temporaries import write_atomically

    fig.tight_layout()
    write_atomically(path, lambda tmp: fig.savefig(tmp, format="png", dpi=dpi), "--plot")


def range_help(key: str) -> str:
    """The allowed interval of RANGES[key] for an option's help, e.g. "[2, 4096]": the interval the check enforces."""
    return RANGES[key].text()


def _limit_key(name: str) -> str:
    """The key of a list option's maximum count in turbgen.theory.ranges.LIMITS."""
    return {"--planes": "planes", "--gates": "planes", "--seeds": "seeds", "--speeds": "speeds"}.get(name, "points")


def parse_floats(text: str, name: str) -> list[float]:
    """'a,b,c' -> [a, b, c] (finite floats, at most the option's LIMITS count)."""
    items = text.split(",")
    if not text.strip():
        raise click.BadParameter(f"{text!r} holds no number", param_hint=name)
    if not all(v.strip() for v in items):  # '0,,50' or '0,50,': a value left out, not a list of two
        raise click.BadParameter(f"{text!r} has an empty entry (write numbers separated by single commas)",
                                 param_hint=name)
    limit = LIMITS[_limit_key(name)]
    if len(items) > limit:
        raise click.BadParameter(f"{len(items)} values is more than the maximum {limit}", param_hint=name)
    for v in items:
        try:
            x = float(v)
        except ValueError:
            raise click.BadParameter(f"{v.strip()!r} in {text!r} is not a number", param_hint=name) from None
        if not math.isfinite(x):
            raise click.BadParameter(f"{v.strip()!r} in {text!r} is not a finite number", param_hint=name)
    return [float(v) for v in items]


def parse_range(text: str, name: str) -> list[float]:
    """'start:stop:step' -> start, start+step, ... <= stop (inclusive, 1e-9 relative tolerance); the count is
    checked against the option's LIMITS before the list is built."""
    parts = text.split(":")
    try:
        start, stop, step = (float(p) for p in parts)
    except ValueError:
        raise click.BadParameter(f"{text!r} is not start:stop:step (three numbers)", param_hint=name) from None
    if not (step > 0 and stop >= start and all(map(math.isfinite, (start, stop, step)))):
        raise click.BadParameter(f"{text!r} needs finite numbers, step > 0 and stop >= start", param_hint=name)
    n = math.floor((stop - start) / step * (1 + 1e-9) + 1e-9) + 1.0  # a float: 50:1e300:1 has ~1e300 values
    limit = LIMITS[_limit_key(name)]
    if n > limit:
        raise click.BadParameter(f"{text!r} gives {count_text(n)} values, more than the maximum {limit}",
                                 param_hint=name)
    return [round(start + i * step, 9) for i in range(int(n))]


def parse_ints(text: str, name: str) -> list[int]:
    """'1-21' or '1,4,7' or '1-3,9' -> sorted unique non-negative ints (turbgen.theory.ranges.parse_ints)."""
    try:
        return ranges.parse_ints(text, _limit_key(name))
    except ParameterError as exc:
        raise click.BadParameter(str(exc), param_hint=name) from None


def plane_positions(planes: list[float] | None, gates: list[float] | None) -> list[float] | None:
    """x positions [m] from --planes (taken as given) or --gates (the rotor plane 0 added); None if neither."""
    if planes is not None and gates is not None:
        raise click.UsageError("give --planes or --gates, not both")
    if planes is not None:
        return list(planes)
    if gates is not None:
        return [0.0, *gates]
    return None


def iec_class_options(help_text: str):
    """``--iec-class`` (turbine class and turbulence category, e.g. IIB) and its deprecated hidden alias ``--class``
    (which ``kaimal`` uses for the turbulence class alone); :func:`resolve_iec_class` merges the two arguments."""
    return stacked([click.option("--iec-class", "iec_class", default=None, help=help_text),
                    click.option("--class", "class_alias", hidden=True, default=None,
                                 help="Deprecated alias of --iec-class.")])


def resolve_iec_class(iec_class: str | None, class_alias: str | None, command: str) -> str | None:
    """The turbine class given as --iec-class or, with a warning on stderr, as the deprecated --class."""
    if iec_class is not None and class_alias is not None:
        raise click.UsageError("give --iec-class only (--class is its deprecated alias)")
    if class_alias is not None:
        click.echo(f"turbgen {command}: warning: --class is deprecated here, write --iec-class {class_alias} (the "
                   "turbine class and turbulence category; `turbgen kaimal --class` is the turbulence class)", err=True)
    return class_alias if iec_class is None else iec_class
