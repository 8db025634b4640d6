"""`turbgen fit mann DATA`: the Mann model fitted to a point-series file or a store."""

from __future__ import annotations

import json

import click

from turbgen.errors import ParameterError
from turbgen.spec.defaults import MANN_DEFAULTS
from turbgen.theory.params import LIFETIMES

PLOT_NAME = "fit_mann.png"


def plots_dir(name: str, meta_key: str):
    """--plots callback: a directory that can be made, without an existing ``name`` unless --overwrite (recorded in
    ``ctx.meta[meta_key]``), checked before the fit."""

    def check(ctx, param, value):
        if value is None:
            return None
        from turbgen.store.paths import check_output_path

        p = check_output_path(value, "--plots", create_parents=True)
        if p.exists() and not p.is_dir():
            raise ParameterError(f"--plots = {value!r} is a file, not a directory")
        if (p / name).exists() and not ctx.meta.get(meta_key):
            raise ParameterError(f"--plots = {value!r} holds {name}; pass --overwrite to replace it")
        return p

    return check


def yz(text: str) -> tuple[float, float]:
    """(y, z) [m] of a --point "Y,Z"."""
    try:
        y, z = (float(v) for v in text.split(","))
    except ValueError:
        raise ParameterError(f"--point {text!r} must be Y,Z: two numbers [m] separated by a comma") from None
    return y, z


def _remember_overwrite(ctx, param, value):
    ctx.meta["fit_overwrite"] = value


@click.command("mann", short_help="Fit ae, L, Gamma (and the evolution time) to measured data.")
@click.argument("data", type=click.Path())
@click.option("--U", "U", type=float, default=None,
              help="Mean wind speed U [m/s] of k1 = 2 pi f / U for fluctuation data (default: the mean of u of "
                   "total-wind data; a store holds its own).")
@click.option("--nperseg", type=int, default=None, help="Welch segment length [samples] (default ~nt/8, a power of 2).")
@click.option("--point", "points", multiple=True, metavar="Y,Z",
              help="For a store: fit the series at this grid point (y, z) [m] of every plane (repeat for a mast) "
                   "against the grid's expectation there; default a sub-lattice of 8 x 8 points.")
@click.option("--gamma", type=float, default=None,
              help=f"For a lidar record: the Gamma held (default {MANN_DEFAULTS['gamma']:g}, the generator's; its LOS "
                   "spectra do not identify it).")
@click.option("--bootstrap", type=int, default=0, metavar="B",
              help="For a store: refit B fields made at the fitted parameters and print the bootstrap sd beside "
                   "the analytic one (default 0: off).")
@click.option("--lifetime", type=click.Choice(LIFETIMES), default=None,
              help="Eddy lifetime of the model: guo (Guo et al. 2023, Eq. 6; the generator's default) or mann "
                   "(Mann 1994, as HAWC2 and wetb). Default: a store's own, else guo.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON: {name: {value, ci95, held}}, chi2_dof, flags, ...")
@click.option("--plots", "plots", type=click.Path(), default=None, callback=plots_dir(PLOT_NAME, "fit_overwrite"),
              help=f"Directory for {PLOT_NAME}: the band spectra with 95 % bars and the fitted model.")
@click.option("--overwrite", is_flag=True, is_eager=True, expose_value=False, callback=_remember_overwrite,
              help=f"Replace an existing {PLOT_NAME} in --plots.")
@click.pass_context
def fit_mann_command(ctx, data, U, nperseg, points, gamma, bootstrap, lifetime, as_json, plots):
    """Fit ae, L, Gamma of the Mann model to DATA: a point-series JSON or CSV file (sensors with u, v, w), a store, a
    TurbSim .bts, a HAWC2 .htc whose mann block names the boxes, or a lidar record: a `turbgen lidar --out`
    dataset or a line-of-sight CSV or netCDF file (ae, L and the evolution time from gates along x; Gamma held).

    Weighted least squares over the Welch spectra of u, v, w and the u-w co-spectrum, each band weighted by the
    estimator's covariance; a store against its grid's expectation, sensors against the continuous model. Prints
    the values with 95 % intervals and chi2/dof; exit 2 with one line when the fit is flagged (no convergence, a
    range boundary)."""
    from turbgen.api.fit import fit_mann

    result = fit_mann(data, U=U, nperseg=nperseg, points=[yz(p) for p in points] or None, bootstrap=bootstrap,
                      gamma=gamma, lifetime=lifetime)
    report(ctx, result, as_json, plots, PLOT_NAME)


def report(ctx, result, as_json: bool, plots, name: str) -> None:
    """Print a fit (JSON or its table), write its figure ``plots / name``, exit 2 with one line when flagged."""
    click.echo(json.dumps(result.to_dict()) if as_json else result.table())
    if plots is not None:
        plots.mkdir(parents=True, exist_ok=True)
        result.plot(plots / name)
    if result.flags:
        click.echo(f"Error: the fit is not reliable: {'; '.join(result.flags)}", err=True)
        ctx.exit(2)
