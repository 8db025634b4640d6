"""The grid options of `turbgen mann|kaimal`, combined by the Python API's rule (turbgen.api.fields: run file <
preset < typed options); no option carries a default of its own (turbgen.spec.defaults, shown in the help)."""

from __future__ import annotations

import functools
from collections.abc import Mapping

import click

from turbgen import fft
from turbgen.cli.options import parse_floats, parse_range, range_help, stacked


def _list(parser, name):
    return lambda ctx, param, value: None if value is None else parser(value, name)


def grid_options(defaults: Mapping):
    """Decorator adding --planes, --gates, --nt, --dt, --ny, --nz, --dy, --dz, their help showing ``defaults`` (the
    model's grid table of turbgen.spec.defaults) and the allowed ranges (turbgen.theory.ranges, as checked)."""
    return stacked([
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
    ])


def constraint_options(sources: str, after: str):
    """Decorator adding --constrain (point series JSON or CSV, ``sources`` the further formats, ``after`` closing its
    help), --noise and --conditional-mean."""
    return stacked([
        click.option("--constrain", "constrain", multiple=True, type=click.Path(),
                     help=f"Condition the field on the measurements of FILE: point time series (JSON, "
                     f"schemas/constraints.schema.json, or CSV){sources}; repeatable. The field is a sample of the "
                     f"model conditioned on them (Hoffman & Ribak 1991){after}."),
        click.option("--noise", type=float, help="With --constrain: measurement-noise sigma [m/s] >= 0 of every value "
                     "(default: each file's noise_m_s, else 0 = the field passes through the data)."),
        click.option("--conditional-mean", "conditional_mean", is_flag=True, help="With --constrain: write the "
                     "conditional mean (the optimal linear reconstruction, no random part)."),
    ])


def fft_backend_option(command):
    """Decorator adding --fft-backend: the command's body runs with that FFT backend (turbgen.fft.use; default: the
    TURBGEN_FFT_BACKEND environment variable, else pyfftw). An unknown name is a one-line error before any output.
    Place it right under ``@click.command()``."""

    @click.option("--fft-backend", "fft_backend",
                  help=f"FFT backend: {', '.join(fft.names())} (default: ${fft.ENVIRONMENT_VARIABLE}, else "
                  f"{fft.DEFAULT}); changes the field at float32 round-off only, recorded in the store.")  # fmt: skip
    @functools.wraps(command)
    def with_backend(fft_backend, **opt):
        with fft.use(fft_backend):
            return command(**opt)

    return with_backend
