"""`turbgen validate STORE`: re-estimate spectra and coherences and compare them with the model."""

from __future__ import annotations

import json
import sys

import click

from turbgen.cli import run_imports
from turbgen.spec.defaults import DEFAULT_ROTOR_RADIUS_M


@click.command("validate")
@click.argument("store", type=click.Path(path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON (stable keys) instead of a table.")
@click.option("--plots", "plots_dir", type=click.Path(file_okay=False, path_type=str), default=None,
              help="Write one PNG per comparison (estimate, 95 % band, theory) into this directory (PNGs already "
              "there need --overwrite).")
@click.option("--overwrite", is_flag=True, help="Replace PNGs already in the --plots directory.")
@click.option("--rotor-radius", "rotor_radius", type=float, default=None,
              help=f"Rotor radius R [m] of the rotor-effective wind speed (mean of u over the points within R); "
              f"default {DEFAULT_ROTOR_RADIUS_M:g} m, or the largest disc inside a smaller grid (widened to the nearest grid points when it holds none).")
def validate(store, as_json, plots_dir, overwrite, rotor_radius):
    """Validate the field store STORE against its model (Mann or Kaimal).

    Exit code 0 when every metric passes, 1 when a metric fails, 2 for usage errors or a path
    that is not a complete turbgen store."""
    with run_imports():
        from turbgen.api.products import check_plots_dir
        from turbgen.validation import validate as run_validation

    if plots_dir is not None:
        check_plots_dir(plots_dir, overwrite, "--plots")
    report = run_validation(store, rotor_radius_m=rotor_radius)
    if plots_dir is not None:
        click.echo(f"wrote {len(report.plots(plots_dir))} plots to {plots_dir}", err=True)
    click.echo(json.dumps(report.to_dict(), indent=1) if as_json else report.table())
    sys.exit(0 if report.passed else 1)
