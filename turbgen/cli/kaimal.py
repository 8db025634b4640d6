"""`turbgen kaimal`: a Kaimal 4D field (IEC spectra + yz coherence, evoTurb longitudinal coherence) to a store."""

from __future__ import annotations

import sys

import click

from turbgen.cli.options import parse_floats, parse_range, plane_positions
from turbgen.resources import format_bytes
from turbgen.runs.config import read_config
from turbgen.runs.kaimal import (
    LONG_COMPONENTS,
    VW_COHERENCE,
    KaimalRun,
    memory_needed,
    run_kaimal,
)
from turbgen.store.paths import check_output_path
from turbgen.theory.coherence_models import LONGITUDINAL_MODELS
from turbgen.theory.kaimal import IEC_IREF
from turbgen.theory.ranges import LIMITS

# option name -> key of the run mapping (KaimalRun.from_mapping)
_KEYS = {
    "U": "U_m_s", "turb_class": "turb_class", "hub_height": "hub_height_m", "sigma": "sigma_m_s",
    "lengths": "length_scales_m", "ayz": "a_yz", "lc": "lc_m", "long_model": "long_model", "ax": "a_x",
    "bx": "b_x", "long_components": "long_components", "vw_coherence": "vw_coherence", "rescale": "rescale",
    "seed": "seed",
}
_GRID_KEYS = {"nt": "nt", "dt": "dt_s", "ny": "ny", "nz": "nz", "dy": "dy_m", "dz": "dz_m"}


def _three(name):
    def convert(ctx, param, value):
        if value is None:
            return None
        values = parse_floats(value, name)
        if len(values) != 3:
            raise click.BadParameter(f"{value!r} needs three values (u, v, w)", param_hint=name)
        return values
    return convert


def _list(parser, name):
    return lambda ctx, param, value: None if value is None else parser(value, name)


@click.command()
@click.option("--U", "U", type=float, default=16.0, show_default=True, help="Hub-height mean wind speed [m/s].")
@click.option("--class", "turb_class", type=click.Choice(list(IEC_IREF)), default="A", show_default=True,
              help="IEC turbulence class (NTM sigma_1 = Iref (0.75 U + 5.6)).")
@click.option("--hub-height", type=float, default=90.0, show_default=True,
              help="Hub height [m] (Lambda1 = 0.7 z below 60 m, else 42 m).")
@click.option("--sigma", callback=_three("--sigma"), help="Explicit sigma_u,sigma_v,sigma_w [m/s] (overrides --class).")
@click.option("--lengths", callback=_three("--lengths"), help="Explicit Kaimal L1,L2,L3 [m] (e.g. Table 1 classes).")
@click.option("--preset", help="Stability preset (paper 000 Tables 1-2: unstable, neutral, stable, or from "
              "--presets-file): sets sigma, L, a_yz, Lc and the longitudinal model; typed options override it.")
@click.option("--presets-file", type=click.Path(dir_okay=False), help="User presets (TOML or JSON).")
@click.option("--ayz", type=float, help="yz coherence decay a_yz [-] (default 12).")
@click.option("--lc", type=float, help="yz coherence scale Lc [m] (default 8.1 Lambda1).")
@click.option("--long-model", type=click.Choice(list(LONGITUDINAL_MODELS)), default="exp", show_default=True,
              help="Longitudinal coherence model (paper 000 Eq. 18, Simley-Pao, Kristensen).")
@click.option("--ax", type=float, help="a_x of the exp model [-] (default 1.8, Table 2 neutral, gamma 400 s).")
@click.option("--bx", type=float, help="b_x of the exp model [1/m] (default 1.49e-4).")
@click.option("--long-components", type=click.Choice(LONG_COMPONENTS), default="u", show_default=True,
              help="Components given the longitudinal coherence (evoTurb: u).")
@click.option("--vw-coherence", type=click.Choice(VW_COHERENCE), default="white", show_default=True,
              help="v, w in the yz plane: white (IEC / TurbSim IECKAI) or exp (extension: u's coherence).")
@click.option("--planes", callback=_list(parse_floats, "--planes"), help="Plane positions x [m], e.g. 0,50,100.")
@click.option("--gates", callback=_list(parse_range, "--gates"),
              help="Range gates start:stop:step [m]; planes = rotor 0 + gates (default 50:170:13.3).")
@click.option("--nt", type=int, default=4096, show_default=True, help="Time samples.")
@click.option("--dt", type=float, default=0.5, show_default=True, help="Time step [s].")
@click.option("--ny", type=int, default=31, show_default=True, help="Lateral points.")
@click.option("--nz", type=int, default=31, show_default=True, help="Vertical points.")
@click.option("--dy", type=float, default=5.0, show_default=True, help="Lateral spacing [m].")
@click.option("--dz", type=float, help="Vertical spacing [m] (default: --dy).")
@click.option("--chunks", type=int,
              help="Time samples per store chunk (default min(nt, 1024)); never changes the field.")
@click.option("--config", "config", type=click.Path(dir_okay=False), help="JSON/TOML run file; options typed on the "
              "command line override it.")
@click.option("--threads", type=click.IntRange(min=1, max=LIMITS["threads"]), help="FFT threads (default: all cores); never changes the field.")
@click.option("--seed", type=int, default=1, show_default=True, help="Random seed (>= 0).")
@click.option("--out", type=click.Path(), help="Output store (default kaimal_U<U>_<class or preset>_s<seed>.zarr, "
              "plus _p<digest> when other parameters differ from the class or preset).")
@click.option("--overwrite", is_flag=True, help="Replace an existing store.")
@click.option("--rescale", is_flag=True, help="Scale spectra so the expected sigma is the nominal one (recorded in "
              "the store); default: spectra follow Eq. 11 over the resolved band.")
@click.pass_context
def kaimal(ctx, **opt):
    """Kaimal 4D field: IEC spectra and yz coherence per plane, exponential longitudinal coherence between planes."""
    source = ctx.get_parameter_source
    typed = {name for name in opt if source(name) == click.core.ParameterSource.COMMANDLINE}
    mapping = read_config(opt["config"], "kaimal-run") if opt["config"] else {}
    grid = dict(mapping.get("grid", {}))
    if "turb_class" not in typed and ("sigma" in typed or ("sigma_m_s" in mapping and "turb_class" not in mapping)):
        opt["turb_class"] = None  # explicit sigmas: no class to record
        if "sigma" in typed:
            mapping.pop("turb_class", None)
    if opt["preset"] is not None:
        from turbgen.presets import kaimal_run_keys, load_presets

        user = load_presets(opt["presets_file"]) if opt["presets_file"] else None
        U = opt["U"] if "U" in typed or "U_m_s" not in mapping else mapping["U_m_s"]
        cls = opt["turb_class"] if "turb_class" in typed else None
        preset_keys = kaimal_run_keys(opt["preset"], U, user=user, turb_class=cls)
        mapping.update(preset_keys)
        if "turb_class" not in typed:
            opt["turb_class"] = None
    elif opt["presets_file"]:
        raise click.UsageError("--presets-file needs --preset")
    else:
        preset_keys = None
    # typed options override the run file and preset; defaults fill what neither gives
    for name, key in _KEYS.items():
        if name in typed or (key not in mapping and opt[name] is not None):
            mapping[key] = opt[name]
    for name, key in _GRID_KEYS.items():
        if name in typed or (key not in grid and opt[name] is not None):
            grid[key] = opt[name]
    x_m = plane_positions(opt["planes"], opt["gates"])
    if x_m is not None:
        grid["x_m"] = x_m
    mapping["grid"] = grid
    run = KaimalRun.from_mapping(mapping)
    g = run.grid
    out = opt["out"] if opt["out"] is not None else run.default_store_name(opt["preset"], preset_keys)
    check_output_path(out)
    k = run.kaimal
    click.echo(f"turbgen kaimal: U {run.U_m_s:g} m/s, sigma {', '.join(f'{s:.3g}' for s in k.sigma_m_s)} m/s, "
               f"L {', '.join(f'{s:.4g}' for s in k.length_scales_m)} m, a_yz {k.a_yz:g}, Lc {k.lc_m:g} m, "
               f"long {run.long_model} {run.effective_long_parameters()} on {run.long_components}, seed {run.seed}")
    click.echo(f"  grid (t, x, y, z) = {g.nt} x {g.nx} x {g.ny} x {g.nz}, dt {g.dt_s:g} s, dy {g.dy_m:g} m, "
               f"dz {g.dz_m:g} m, planes x = {', '.join(f'{x:g}' for x in g.x_m)} m")
    click.echo(f"  memory ~{format_bytes(memory_needed(g))}, output {format_bytes(3 * g.nbytes_per_component())} "
               f"float32 -> {out}")
    s = run_kaimal(run, out, overwrite=opt["overwrite"], chunk_t=opt["chunks"], progress=sys.stderr.isatty(),
                   threads=opt["threads"])
    exp = ", ".join(f"{v:.3f}" for v in s["expected_sigma"])
    clip = ""
    if s["yz_clip_error"] > 0 or s["long_clip_error"] > 0:
        clip = f"; CLIPPED embedding, coherence error <= {max(s['yz_clip_error'], s['long_clip_error']):.2g}"
    click.echo(f"wrote {s['path']} in {s['seconds']:.1f} s: sigma u/v/w {s['sigma_u']:.3f}/{s['sigma_v']:.3f}/"
               f"{s['sigma_w']:.3f} m/s (expected {exp}; max torus {s['max_torus'][0]}x{s['max_torus'][1]}{clip})")
