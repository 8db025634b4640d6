"""The grid options of `turbgen mann|kaimal`. Their values make the run by the rule of the Python API
(turbgen.api.fields.mann_run_mapping / kaimal_run: run file < preset < typed options); missing keys take the defaults
of turbgen.spec.defaults (applied by the model's from_mapping, shown in the options' help), so no option carries a
default of its own.
"""

from __future__ import annotations

from collections.abc import Mapping

import click

from turbgen.cli.options import parse_floats, parse_range, range_help


def _list(parser, name):
    return lambda ctx, param, value: None if value is None else parser(value, name)


def grid_options(defaults: Mapping):
    """Decorator adding --planes, --gates, --nt, --dt, --ny, --nz, --dy, --dz, their help showing ``defaults``
    (the model's grid table of turbgen.spec.defaults) and the allowed ranges (turbgen.theory.ranges, the table
    the checks use)."""
    opts = [
        click.option("--planes", callback=_list(parse_floats, "--planes"),
                     help="Plane positions x [m upstream], e.g. 0,50,100."),
        click.option("--gates", callback=_list(parse_range, "--gates"),
                     help="Range gates start:stop:step [m]; planes = rotor 0 + gates (default 50:170:13.3)."),
        click.option("--nt", type=int, help=f"Time samples, {range_help('nt')} (default {defaults['nt']})."),
        click.option("--dt", type=float,
                     help=f"Time step [s], {range_help('dt_s')} (default {defaults['dt_s']:g}; dx = U dt)."),
        click.option("--ny", type=int, help=f"Lateral points, {range_help('ny')} (default {defaults['ny']})."),
        click.option("--nz", type=int, help=f"Vertical points, {range_help('nz')} (default {defaults['nz']})."),
        click.option("--dy", type=float, help=f"Lateral spacing [m], {range_help('dy_m')} (default {defaults['dy_m']:g})."),
        click.option("--dz", type=float, help=f"Vertical spacing [m], {range_help('dz_m')} (default: --dy)."),
    ]

    def add(f):
        for opt in reversed(opts):
            f = opt(f)
        return f

    return add
