"""`turbgen theory lidar`: the lidar-rotor coherence, Wiener gain and filter cut-off of a lidar (no store)."""

from __future__ import annotations

import json

import click
import numpy as np

from turbgen.cli.options import parse_floats, plot_figure, save_plot
from turbgen.errors import ParameterError
from turbgen.spec.defaults import MANN_DEFAULTS
from turbgen.spec.models import DECLARATIONS


@click.command("lidar", short_help="Lidar-rotor coherence, Wiener gain and cut-off of a lidar (no store).")
@click.option("--model", type=click.Choice([d.name for d in DECLARATIONS if d.preview]), default="mann",
              show_default=True)
@click.option("--preset", type=click.Choice(["unstable", "neutral", "stable"]), default="neutral",
              show_default=True, help="Stability class (Guo et al. 2023 Table 1/2).")
@click.option("--U", "U", type=float, default=MANN_DEFAULTS["U_m_s"], show_default=True, help="Mean wind speed U [m/s].")
@click.option("--lidar", "lidar_name", default="nacelle-4beam", show_default=True,
              help="Lidar preset (nacelle-4beam, spinner-cw, spinner-pulsed, nacelle-1beam) or a TOML/JSON file.")
@click.option("--radius", type=float, default=None, help="Rotor radius R [m]; default: the lidar preset's turbine.")
@click.option("--f", "f_text", default=None, help="Frequencies a,b,c [Hz]; default 60 log-spaced, 0.005..0.3 Hz.")
@click.option("--frozen", is_flag=True, help="Frozen turbulence (no evolution between gates and rotor).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON: f, coh2_RL, G_RL, k05_rad_m, cutoff_hz, ...")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default=None,
              help="Write a PNG of gamma^2_RL and |G_RL| (Guo et al. 2023 Fig. 4 style).")
def lidar_theory(model, preset, U, lidar_name, radius, f_text, frozen, as_json, plot_path):
    """Lidar-rotor coherence gamma^2_RL, Wiener gain |G_RL|, -3 dB cut-off and k_0.5 of a lidar."""
    from turbgen.virtual_lidar.description import load_lidar
    from turbgen.virtual_lidar.preview import DEFAULT_F_HZ, preview_spectra, summarise

    lidar = load_lidar(lidar_name)
    f = np.array(parse_floats(f_text, "--f")) if f_text is not None else DEFAULT_F_HZ
    if np.any(f <= 0):
        raise ParameterError(f"--f values must be > 0 Hz, got {f.min():g}")
    spectra = preview_spectra(model, lidar, U, preset=preset, f_hz=f, radius_m=radius, frozen=frozen)
    out = {"model": model, "preset": preset, "U_m_s": U, "lidar": lidar.name,
           "rotor_radius_m": radius or lidar.rotor_radius_m, **summarise(spectra, lidar, U)}
    if plot_path:
        _plot(plot_path, out)
    if as_json:
        click.echo(json.dumps(out))
        return
    click.echo(f"{model} {preset} U = {U:g} m/s, lidar {lidar.name}, rotor R = {out['rotor_radius_m']:g} m")
    click.echo(f"{'f [Hz]':>10} {'coh2_RL':>9} {'|G_RL|':>8}")
    for fi, c, g in zip(out["f"], out["coh2_RL"], out["G_RL"]):
        click.echo(f"{fi:10.4g} {c:9.4f} {g:8.4f}")
    click.echo(f"cut-off (-3 dB of |G_RL|): {out['cutoff_hz']:.4f} Hz; k_0.5 = {out['k05_rad_m']:.4f} rad/m "
               f"(d_eddy,min = {out['d_eddy_min_m']:.0f} m)")
    if "buffer_time_s" in out:
        click.echo(f"first-order filter delay {out['filter_delay_s']:.2f} s; buffer time "
                   f"{out['buffer_time_s']:.2f} s (nearest gate, scan {out['scan_time_s']:g} s, no pitch delay)")


def _plot(path, out):
    fig, (a1, a2) = plot_figure(ncols=2, figsize=(10, 4))
    a1.semilogx(out["f"], out["coh2_RL"])
    a1.axhline(0.5, color="0.6", lw=0.8)
    a1.set(xlabel="f [Hz]", ylabel="γ²_RL [-]", ylim=(0, 1.02), title=f"{out['model']} {out['preset']}")
    a2.semilogx(out["f"], out["G_RL"])
    a2.axhline(10 ** (-3 / 20), color="0.6", lw=0.8)
    a2.axvline(out["cutoff_hz"], color="C3", lw=0.8, label=f"cut-off {out['cutoff_hz']:.4f} Hz")
    a2.set(xlabel="f [Hz]", ylabel="|G_RL| [-]", ylim=(0, 1.05), title=f"lidar {out['lidar']}")
    a2.legend()
    save_plot(fig, path, 110)
