"""`turbgen lidar STORE`: the virtual lidar on a field store; `turbgen lidar optimize` (lidar theory).

A first word that is not a subcommand (``run``, ``optimize``) is the store: ``turbgen lidar STORE`` is
``turbgen lidar run STORE``."""

from __future__ import annotations

import importlib
import json
import sys

import click

from turbgen.errors import TurbgenError
from turbgen.spec.mean_wind import CCW_NOTE

# subcommands from other modules, imported on use; a module not in this build is not listed
EXTERNAL = {"optimize": ("turbgen.cli.lidar_optimize", "optimize")}


class LidarGroup(click.Group):
    """A group whose unknown first word is the STORE of the default subcommand ``run``."""

    def list_commands(self, ctx):
        return sorted({*super().list_commands(ctx), *(n for n in EXTERNAL if self.get_command(ctx, n))})

    def get_command(self, ctx, cmd_name):
        cmd = super().get_command(ctx, cmd_name)
        if cmd is None and cmd_name in EXTERNAL:
            module, attr = EXTERNAL[cmd_name]
            try:
                cmd = getattr(importlib.import_module(module), attr)
            except ModuleNotFoundError as exc:
                if exc.name != module:
                    raise
                return None
        return cmd

    def resolve_command(self, ctx, args):
        if args and not args[0].startswith("-") and self.get_command(ctx, args[0]) is None:
            args = ["run", *args]
        return super().resolve_command(ctx, args)


@click.group("lidar", cls=LidarGroup, invoke_without_command=False)
def lidar():
    """Virtual lidar on a store (`turbgen lidar STORE`, same as `turbgen lidar run STORE`)."""


@lidar.command("run", short_help="Sample a store with a lidar; its preview quality against theory.")
@click.argument("store", type=click.Path(path_type=str))
@click.option("--lidar", "lidar_name", default=None,
              help="lidar preset name or TOML/JSON lidar file (default: the 4-beam pulsed lidar of Guo et al. 2023, Table 3)")
@click.option("--out", type=click.Path(path_type=str), default=None,
              help="write the lidar dataset (zarr: v_los, u_LL, u_RR, TI, every lidar parameter) here")
@click.option("--overwrite", is_flag=True, help="replace an existing --out dataset")
@click.option("--rotor-radius", "rotor_radius", type=float, default=None,
              help="rotor radius R [m] of u_RR (default 63 m, or the largest disc inside a smaller grid, widened to the nearest grid points when it holds none)")
@click.option("--mean-wind/--no-mean-wind", default=False, show_default=True,
              help="add the mean wind U (1 + z/h_hub)^alpha to u before projecting (default: fluctuations only)")
@click.option("--shear", "shear_exponent", type=float, default=0.2, show_default=True,
              help="power-law shear exponent alpha of --mean-wind")
@click.option("--profile", default=None, metavar="KIND:VALUE",
              help="--mean-wind profile as turbgen export takes it: power:ALPHA | log:z0=Z0[,d=D] | table:FILE "
                   "(replaces --shear)")
@click.option("--veer", type=float, default=None, metavar="DEG_PER_M",
              help=f"--mean-wind veer [deg/m], as turbgen export: {CCW_NOTE}")
@click.option("--mean-history", type=click.Path(dir_okay=False), default=None, metavar="FILE",
              help="--mean-wind hub-height history CSV (t, U [, direction]), as turbgen export; directions "
                   f"{CCW_NOTE}")
@click.option("--json", "as_json", is_flag=True, help="print the result as JSON instead of text")
@click.option("--plots", "plots_dir", type=click.Path(file_okay=False, path_type=str), default=None,
              help="write gamma^2_RL and |G_RL| plots (simulated with 95 % band, theory) into this directory")
def run(store, lidar_name, out, overwrite, rotor_radius, mean_wind, shear_exponent, profile, veer, mean_history,
        as_json, plots_dir):
    """Sample STORE with a lidar; report simulated preview quality (MCB, cut-off, TI).

    Exit code 0 when the simulated coherence agrees with theory, 1 when it departs beyond the
    estimator's uncertainty, 2 for usage errors (nothing written)."""
    from turbgen.api.products import lidar_report

    try:
        result = lidar_report(store, lidar_name, out, overwrite, rotor_radius, mean_wind, shear_exponent, profile,
                              veer, mean_history)
    except TurbgenError as exc:
        from turbgen.cli import user_error

        raise user_error(exc) from None
    if out is not None:
        path = result.write(out, overwrite=overwrite)
        click.echo(f"wrote {path}", err=True)
    if plots_dir is not None:
        click.echo(f"wrote {len(result.plots(plots_dir))} plots to {plots_dir}", err=True)
    click.echo(json.dumps(result.to_dict(), indent=1) if as_json else result.text())
    sys.exit(0 if result.passed else 1)

