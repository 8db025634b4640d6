"""`turbgen export STORE --format ... --out PATH`: write a store for InflowWind, HAWC2, the
lidar simulator, the 4D Mann generator's scripts or HDF5."""

from __future__ import annotations

import click

from turbgen.cli import run_imports
from turbgen.spec.mean_wind import CCW_NOTE, CW_NOTE, DEFAULT_SHEAR_EXPONENT

# turbgen.exporters.EXPORTERS' keys (tests/cli/test_entry_point.py checks): the exporters import the store's zarr,
# which --help and a bad --format need not wait for
FORMATS = ("bts", "wnd", "evo", "hawc2", "mt4d", "hdf5")


@click.command("export")
@click.argument("store", type=click.Path(file_okay=True, dir_okay=True))
@click.option("--format", "fmt", required=True, type=click.Choice(FORMATS),
              help="bts (TurbSim), wnd (Bladed .wnd+.sum), evo (lidar-simulator ROOT.evo/.wnd/.sum), "
                   "hawc2 (ROOT_u/v/w.bin), mt4d, hdf5.")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False),
              help="Output file, or root name for wnd/evo/hawc2.")
@click.option("--plane", type=int, default=None, help="Plane index to export (default: the rotor plane, x = 0); evo: the plane of ROOT.wnd (ROOT.evo holds every plane).")
@click.option("--hub-height", "hub_height_m", type=float, default=None, help="Hub height [m] (default: the store's).")
@click.option("--shear-exponent", "shear_exponent", type=float, default=None,
              help=f"Power-law exponent of the mean profile added to u (InflowWind formats; default {DEFAULT_SHEAR_EXPONENT:g}).")
@click.option("--profile", "profile", default=None, metavar="KIND:VALUE",
              help="Mean profile added (InflowWind/HAWC2 formats): power:ALPHA | log:z0=Z0[,d=D] (roughness and "
                   "displacement, m) | table:FILE (CSV rows z [m], U [m/s] [, direction deg]; speeds scaled so the "
                   f"table's value at hub height is the hub mean; directions {CCW_NOTE}). Default power:0.2.")
@click.option("--veer", "veer_deg_per_m", type=float, default=None, metavar="DEG_PER_M",
              help=f"Direction change with height [deg/m], (u, v) turned per height about the hub, {CCW_NOTE}: "
                   "northern-hemisphere veer is negative.")
@click.option("--mean-history", "mean_history", type=click.Path(dir_okay=False), default=None, metavar="FILE",
              help="Hub-height mean history: CSV rows t [s], U [m/s] [, direction deg] at the turbine (times within "
                   "the record; linear between rows, end values held); the advection speed stays the store's U; "
                   f"directions {CCW_NOTE}.")
@click.option("--transient", type=click.Choice(["EOG", "EDC", "ECD", "EWS-V", "EWS-H"], case_sensitive=False),
              default=None, help="Superimpose an IEC 61400-1 Ed. 4 transient (Sect. 6.3.3) at the store's U and hub "
                                 "height, from --transient-start; needs --iec-class and --rotor-diameter. It rides "
                                 "on the slices: Taylor's shift keeps the hub mean U.")
@click.option("--iec-class", default=None, help="--transient: turbine class and turbulence category, e.g. IIB.")
@click.option("--rotor-diameter", "rotor_diameter_m", type=float, default=None, help="--transient: rotor diameter D [m].")
@click.option("--transient-start", "transient_start_s", type=float, default=10.0, show_default=True,
              help="--transient: time the event reaches the turbine [s].")
@click.option("--transient-sign", type=click.Choice(["+", "-"]), default="+", show_default=True,
              help=f"--transient: the standard's +-: the shear's sense (EWS) or the direction change's, + {CW_NOTE}.")
@click.option("--tower", is_flag=True, help="bts: add tower points down to the ground.")
@click.option("--periodic/--no-periodic", default=True, show_default=True,
              help="Flag bts/wnd/evo periodic in time (InflowWind wraps instead of starting half a grid upstream).")
@click.option("--drop-below-ground", is_flag=True, help="Drop grid rows at or below the ground instead of refusing.")
@click.option("--runner-files/--no-runner-files", "runner_files", default=True, show_default=True,
              help="Also write the runners' input files beside the wind files: OUT_InflowWind_FORMAT.dat, a complete "
                   "InflowWind v5 input file (bts, wnd, evo, hawc2; wind-file names relative to it), OUT_wind.htc, a "
                   "HAWC2 wind + mann block (hawc2), and OUT_LidarSim_evolution.txt, the LidarSim input file's "
                   "Wind Evolution section (evo).")
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
def export(store, fmt, out, **options):
    """Export STORE to --format; prints the InflowWind input-file lines that load the result."""
    with run_imports():
        from turbgen.exporters import export_store
        from turbgen.exporters.options import ExportOptions, export_request
        from turbgen.store.paths import check_output_path

    check_output_path(out)
    request = export_request(store, fmt, ExportOptions(**options))  # the options' names are ExportOptions' fields
    result = export_store(store, fmt, out, request)
    for p in result.paths:
        click.echo(f"wrote {p}", err=True)
    for note in result.notes:
        click.echo(note if note.startswith("warning: ") else f"note: {note}", err=True)
    for line in result.usage:
        click.echo(f"use: {line}", err=True)
    click.echo("InflowWind input-file lines:")
    for line in result.inflowwind_lines:
        click.echo(line)

