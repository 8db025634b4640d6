"""`turbgen lidar optimize`: Fu et al. (2023)'s brute-force search of a spinner lidar's range and cone angle."""

from __future__ import annotations

import json

import click

from turbgen.cli.options import count_text, evo_seconds, parse_floats
from turbgen.theory.lidar_control import PITCH_DELAY_RANGE_S


@click.command("optimize", short_help="Choose the range and cone angle that maximise k_0.5.")
@click.option("--lidar", "lidar_name", default="spinner-pulsed", show_default=True,
              help="Spinner lidar preset (spinner-cw, spinner-pulsed) or a TOML/JSON spinner lidar file.")
@click.option("--U", "U", type=float, default=18.0, show_default=True, help="Mean wind speed U [m/s].")
@click.option("--ae", type=float, default=0.2882, show_default=True, help="αε^(2/3) [m^(4/3) s^-2].")
@click.option("--L", "L", type=float, default=49.0, show_default=True, help="Mann length scale L [m].")
@click.option("--gamma", type=float, default=3.1, show_default=True, help="Shear anisotropy Γ [-].")
@click.option("--evo", default="400", show_default=True, callback=evo_seconds,
              help="Evolution time constant γ [s], or 'frozen' (no evolution).")
@click.option("--ranges", "ranges_text", default="100:300:20", show_default=True,
              help="Measurement ranges x [m]: a,b,c or start:stop:step.")
@click.option("--cones", "cones_text", default="10:30:2", show_default=True,
              help="Half-cone angles [deg]: a,b,c or start:stop:step.")
@click.option("--pitch-delay", type=float, default=0.9, show_default=True,
              help="Pitch actuator delay T_pitch [s], in [{:g}, {:g}].".format(*PITCH_DELAY_RANGE_S))
@click.option("--json", "as_json", is_flag=True, help="Print every candidate and the optimum as JSON.")
def optimize(lidar_name, U, ae, L, gamma, evo, ranges_text, cones_text, pitch_delay, as_json):
    """Maximise k_0.5 over range x half-cone angle subject to T_buffer >= 0 (Mann space-time theory)."""
    from tqdm import tqdm

    from turbgen.virtual_lidar.description import load_lidar
    from turbgen.virtual_lidar.optimize import optimize_spinner
    from turbgen.theory.params import MannParams

    lidar = load_lidar(lidar_name)
    params = MannParams(ae, L, gamma, evo_time_s=evo)
    ranges = _grid(ranges_text, "--ranges")
    cones = _grid(cones_text, "--cones")
    with tqdm(total=len(ranges) * len(cones), disable=None, desc="candidates") as bar:
        cands, best = optimize_spinner(lidar, params, U, ranges, cones, pitch_delay_s=pitch_delay,
                                       progress=bar.update)
    if as_json:
        click.echo(json.dumps({"candidates": [c.__dict__ for c in cands], "optimum": best and best.__dict__}))
        return
    click.echo(f"{'x [m]':>7} {'phi [deg]':>9} {'k_0.5 [rad/m]':>13} {'cut-off [Hz]':>12} {'T_buffer [s]':>12}")
    for c in cands:
        click.echo(f"{c.range_m:7.0f} {c.half_cone_deg:9.1f} {c.k05_rad_m:13.4f} {c.cutoff_hz:12.4f} "
                   f"{c.buffer_time_s:12.2f}")
    if best is None:
        click.echo("no candidate has T_buffer >= 0: try larger ranges")
    else:
        click.echo(f"optimum: x = {best.range_m:g} m, half-cone {best.half_cone_deg:g} deg, k_0.5 = "
                   f"{best.k05_rad_m:.4f} rad/m, cut-off {best.cutoff_hz:.4f} Hz, T_buffer {best.buffer_time_s:.2f} s")


def _grid(text: str, option: str) -> list[float]:
    """a,b,c or start:stop:step (stop included)."""
    from turbgen.errors import ParameterError

    if ":" in text:
        parts = parse_floats(text.replace(":", ","), option)
        if len(parts) != 3 or parts[2] <= 0 or parts[1] < parts[0]:
            raise ParameterError(f"{option} {text!r}: give start:stop:step with step > 0 and stop >= start")
        n = (parts[1] - parts[0]) / parts[2] + 1e-9 + 1.0  # a float: 100:1e300:1 has ~1e300 values
        if n > 500:
            raise ParameterError(f"{option} {text!r}: {count_text(n)} values, at most 500")
        return [parts[0] + i * parts[2] for i in range(int(n))]
    return parse_floats(text, option)
