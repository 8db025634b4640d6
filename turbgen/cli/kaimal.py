"""`turbgen kaimal`: a Kaimal 4D field (IEC spectra + yz coherence, evoTurb longitudinal coherence) to a store."""

from __future__ import annotations

import sys
from dataclasses import replace

import click

from turbgen.cli import run_imports
from turbgen.cli.options import parse_floats, plane_positions
from turbgen.cli.run_options import constraint_options, fft_backend_option, grid_options
from turbgen.resources import format_bytes
from turbgen.spec.defaults import DEFAULT_A_X, DEFAULT_B_X
from turbgen.spec.defaults import KAIMAL_DEFAULTS as D
from turbgen.spec.defaults import KAIMAL_GRID as G
from turbgen.spec.kaimal import LONG_COMPONENTS, VW_COHERENCE
from turbgen.spec.kaimal import OPTIONS as KAIMAL_OPTIONS
from turbgen.spec.run_inputs import GRID_OPTIONS
from turbgen.theory.coherence_models import LONGITUDINAL_MODELS
from turbgen.theory.kaimal import IEC_IREF
from turbgen.theory.ranges import LIMITS

# the options that make the run (turbgen.spec.run_mapping.kaimal_run)
RUN_OPTIONS = (*KAIMAL_OPTIONS, *GRID_OPTIONS, "planes", "gates")


def _three(name):
    def convert(ctx, param, value):
        if value is None:
            return None
        values = parse_floats(value, name)
        if len(values) != 3:
            raise click.BadParameter(f"{value!r} needs three values (u, v, w)", param_hint=name)
        return values
    return convert


@click.command()
@fft_backend_option
@click.option("--U", "U", type=float, help=f"Hub-height mean wind speed [m/s] (default {D['U_m_s']:g}).")
@click.option("--class", "turb_class", type=click.Choice(list(IEC_IREF)),
              help=f"IEC turbulence class (NTM sigma_1 = Iref (0.75 U + 5.6); default {D['turb_class']}).")
@click.option("--hub-height", type=float,
              help=f"Hub height [m] (Lambda1 = 0.7 z below 60 m, else 42 m; default {D['hub_height_m']:g}).")
@click.option("--sigma", callback=_three("--sigma"), help="Explicit sigma_u,sigma_v,sigma_w [m/s] (overrides --class).")
@click.option("--lengths", callback=_three("--lengths"), help="Explicit Kaimal L1,L2,L3 [m] (e.g. Table 1 classes).")
@click.option("--preset", help="Stability preset (Guo et al. 2023, Tables 1-2: unstable, neutral, stable, or from "
              "--presets-file): sets sigma, L, a_yz, Lc and the longitudinal model; typed options override it.")
@click.option("--presets-file", type=click.Path(dir_okay=False), help="User presets (TOML or JSON).")
@click.option("--ayz", type=float, help="yz coherence decay a_yz [-] (default 12).")
@click.option("--lc", type=float, help="yz coherence scale Lc [m] (default 8.1 Lambda1).")
@click.option("--long-model", type=click.Choice(list(LONGITUDINAL_MODELS)),
              help=f"Longitudinal coherence model (Guo et al. 2023, Eq. 18, Simley-Pao, Kristensen; default "
              f"{D['long_model']}).")
@click.option("--ax", type=float, help=f"a_x of the exp model [-] (default {DEFAULT_A_X:g}, Table 2 neutral, gamma 400 s).")
@click.option("--bx", type=float, help=f"b_x of the exp model [1/m] (default {DEFAULT_B_X:g}).")
@click.option("--long-components", type=click.Choice(LONG_COMPONENTS),
              help=f"Components given the longitudinal coherence (evoTurb: u; default {D['long_components']}).")
@click.option("--vw-coherence", type=click.Choice(VW_COHERENCE),
              help="v, w in the yz plane: white (IEC / TurbSim IECKAI) or exp (extension: u's coherence); "
              f"default {D['vw_coherence']}.")
@click.option("--spectrum", type=click.Path(dir_okay=False),
              help="User spectra instead of the Kaimal ones: a CSV file with the columns f_hz,S_u,S_v,S_w (one-sided "
              "PSDs [m^2/s], band means, e.g. a measured site spectrum) covering the run's lines 1/(nt dt) to "
              "1/(2 dt); recorded in the store.")
@click.option("--coherence", type=click.Path(dir_okay=False),
              help="User yz coherence instead of the IEC exponential (u; v, w with --vw-coherence exp): a CSV file "
              "with the columns f_hz,r_m,coh (un-squared [-], one row per frequency and separation [m]) covering the "
              "run's lines, interpolated in f, linear in r; recorded in the store.")
@grid_options(G)
@click.option("--chunks", type=int,
              help="Time samples per store chunk (default min(nt, 1024)); never changes the field.")
@click.option("--config", "config", type=click.Path(dir_okay=False), help="JSON/TOML run file; options typed on the "
              "command line override it.")
@click.option("--threads", type=click.IntRange(min=1, max=LIMITS["threads"]), help="FFT threads (default: all cores); never changes the field.")
@click.option("--seed", type=int, help=f"Random seed (>= 0; default {D['seed']}).")
@click.option("--out", type=click.Path(), help="Output store (default kaimal_U<U>_<class or preset>_s<seed>.zarr, "
              "plus _p<digest> when other parameters differ from the class or preset).")
@click.option("--overwrite", is_flag=True, help="Replace an existing store.")
@click.option("--rescale", is_flag=True, help="Scale spectra so the expected sigma is the nominal one (recorded in "
              "the store); default: spectra follow Eq. 11 over the resolved band.")
@constraint_options(" or a `turbgen lidar --out` dataset",
                    "; each full-rate series' record mean is removed first (the field has zero record mean)")
def kaimal(**opt):
    """Kaimal 4D field: IEC spectra and yz coherence per plane, exponential longitudinal coherence between planes."""
    if not opt["constrain"] and (opt["noise"] is not None or opt["conditional_mean"]):
        raise click.UsageError("--noise and --conditional-mean need --constrain FILE")
    if opt["presets_file"] and opt["preset"] is None:
        raise click.UsageError("--presets-file needs --preset")
    plane_positions(opt["planes"], opt["gates"])  # --planes and --gates: a usage error
    from turbgen.spec.run_mapping import kaimal_run

    # the run as turbgen.kaimal makes it, and the preset's keys at its U (they also name the default store); a bad
    # value is refused here, before the run's imports
    run, preset_keys = kaimal_run({name: opt[name] for name in RUN_OPTIONS}, opt["config"], opt["preset"],
                                  opt["presets_file"])  # fmt: skip
    with run_imports():
        from turbgen.api.fields import check_kaimal_output
        from turbgen.runs.kaimal import run_kaimal

    if opt["coherence"] is not None:
        run = replace(run, coherence=opt["coherence"])
    g = run.grid
    out = opt["out"] if opt["out"] is not None else run.default_store_name(opt["preset"], preset_keys or None)
    memory, constraints = check_kaimal_output(run, out, opt["chunks"], opt["overwrite"], opt["threads"],
                                              opt["constrain"] or None, opt["noise"])  # before any line
    k = run.kaimal
    spectra = f"user spectra {opt['spectrum'] or '(run file)'}"
    if run.spectrum is None:
        spectra = (f"sigma {', '.join(f'{s:.3g}' for s in k.sigma_m_s)} m/s, "
                   f"L {', '.join(f'{s:.4g}' for s in k.length_scales_m)} m")
    yz = f"a_yz {k.a_yz:g}, Lc {k.lc_m:g} m"
    if run.coherence is not None:
        yz = f"yz coherence {opt['coherence'] or '(run file)'}"
    click.echo(f"turbgen kaimal: U {run.U_m_s:g} m/s, {spectra}, {yz}, "
               f"long {run.long_model} {run.effective_long_parameters()} on {run.long_components}, seed {run.seed}")
    click.echo(f"  grid (t, x, y, z) = {g.nt} x {g.nx} x {g.ny} x {g.nz}, dt {g.dt_s:g} s, dy {g.dy_m:g} m, "
               f"dz {g.dz_m:g} m, planes x = {', '.join(f'{x:g}' for x in g.x_m)} m")
    click.echo(f"  memory ~{format_bytes(memory)}, output {format_bytes(3 * g.nbytes_per_component())} "
               f"float32 -> {out}")
    if constraints is not None:
        from turbgen.runs.constrain import describe_constraints
        from turbgen.runs.constrain_kaimal import run_kaimal_constrained

        s = run_kaimal_constrained(run, out, constraints, noise_m_s=opt["noise"],
                                   conditional_mean=opt["conditional_mean"], overwrite=opt["overwrite"],
                                   chunk_t=opt["chunks"], threads=opt["threads"])  # fmt: skip
        for line in describe_constraints(s["constraints"]):
            click.echo(f"  {line}")
    else:
        s = run_kaimal(run, out, overwrite=opt["overwrite"], chunk_t=opt["chunks"], progress=sys.stderr.isatty(),
                       threads=opt["threads"])
    exp = ", ".join(f"{v:.3f}" for v in s["expected_sigma"])
    clip = ""
    if s["yz_clip_error"] > 0 or s["long_clip_error"] > 0:
        clip = f"; CLIPPED embedding, coherence error <= {max(s['yz_clip_error'], s['long_clip_error']):.2g}"
    dense = f", {s['dense_factor_bins']} bins with dense factors" if s["dense_factor_bins"] else ""
    torus = f"max torus {s['max_torus'][0]}x{s['max_torus'][1]}{dense}"
    click.echo(f"wrote {s['path']} in {s['seconds']:.1f} s: sigma u/v/w {s['sigma_u']:.3f}/{s['sigma_v']:.3f}/"
               f"{s['sigma_w']:.3f} m/s (expected {exp}; {torus}{clip})")
