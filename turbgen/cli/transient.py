"""`turbgen transient KIND --iec-class IIB --U 12 ... --out FILE`: an IEC 61400-1 Ed. 4 deterministic event as an
InflowWind uniform wind file (WindType 2) and its InflowWind input file."""

from __future__ import annotations

import click

from turbgen.cli import run_imports
from turbgen.cli.options import iec_class_options, resolve_iec_class
from turbgen.spec.iec_transient import KINDS, IecTransient
from turbgen.spec.mean_wind import CW_NOTE


@click.command("transient", short_help="Write an IEC 61400-1 transient (EOG, EDC, ECD, EWS) as a uniform "
                                      "wind file.")
@click.argument("kind", type=click.Choice(KINDS, case_sensitive=False))
@iec_class_options("Turbine class and turbulence category, e.g. IIB, IA+ (required).")
@click.option("--U", "V_hub", type=float, required=True, help="Hub-height mean speed V_hub [m/s].")
@click.option("--hub-height", type=float, required=True, help="Hub height [m] (Lambda1, RefHt_Uni).")
@click.option("--rotor-diameter", type=float, required=True, help="Rotor diameter D [m] (EOG, EDC, EWS; RefLength).")
@click.option("--start", type=float, default=10.0, show_default=True, help="Time the event starts [s].")
@click.option("--duration", type=float, default=60.0, show_default=True,
              help="Length of the file [s]; the event must end within it.")
@click.option("--dt", type=float, default=0.05, show_default=True, help="Row spacing during the event [s], [0.001, T/4].")
@click.option("--sign", type=click.Choice(["+", "-"]), default="+", show_default=True,
              help=f"The standard's +-: sense of the shear (EWS) or of the direction change (EDC, ECD; + {CW_NOTE}).")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Uniform wind file to write, e.g. eog.hh.")
@click.option("--runner-files/--no-runner-files", default=True, show_default=True,
              help="Also write OUT_InflowWind_uniform.dat (InflowWind v5, WindType 2) beside it.")
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
def transient(kind, iec_class, class_alias, V_hub, hub_height, rotor_diameter, start, duration, dt, sign, out,
              runner_files, overwrite):
    """Write the IEC 61400-1 Ed. 4 event KIND (EOG, EDC, ECD, EWS-V, EWS-H; Sect. 6.3.3) at V_hub as a uniform wind file.

    The normal wind profile (alpha 0.2) is included; parameters (sigma1, Lambda1, V_e1) come from the class and V_hub.
    To superimpose turbulence, run InflowWind on a turbulent export instead: the uniform file is deterministic."""
    iec_class = resolve_iec_class(iec_class, class_alias, "transient")
    if iec_class is None:
        raise click.UsageError("missing option --iec-class (turbine class and turbulence category, e.g. IIB)")
    with run_imports():
        from turbgen.exporters.uniform_wind import export_transient
        from turbgen.store.paths import check_output_path
    check_output_path(out)
    event = IecTransient(kind, iec_class, V_hub, hub_height, rotor_diameter, start_s=start, duration_s=duration,
                         dt_s=dt, sign=1 if sign == "+" else -1)
    paths, usage = export_transient(event, out, overwrite=overwrite, runner_files=runner_files)
    for p in paths:
        click.echo(f"wrote {p}", err=True)
    click.echo(f"note: {event.describe()}", err=True)
    for line in usage:
        click.echo(f"use: {line}", err=True)
