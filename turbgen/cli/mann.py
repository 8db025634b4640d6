"""`turbgen mann`: the Mann space-time 4D field (Guo et al. 2022) to a zarr store."""

from __future__ import annotations

import sys
from contextlib import contextmanager

import click

from turbgen import resources
from turbgen.cli import run_imports
from turbgen.cli.options import evo_seconds, plane_positions
from turbgen.cli.run_options import constraint_options, fft_backend_option, grid_options
from turbgen.resources import default_threads, parse_size
from turbgen.spec.defaults import MANN_DEFAULTS as D
from turbgen.spec.defaults import MANN_GRID as G
from turbgen.spec.mann import OPTIONS as MANN_OPTIONS
from turbgen.spec.mann import MannRun
from turbgen.spec.run_inputs import GRID_OPTIONS
from turbgen.theory.params import LIFETIMES
from turbgen.theory.ranges import LIMITS

# the options that make the run (turbgen.spec.run_mapping.mann_run_mapping)
RUN_OPTIONS = (*MANN_OPTIONS, *GRID_OPTIONS, "planes", "gates")
_ENERGY = ("ae", "sigma_u", "ti")


def _evo(ctx, param, value):
    seconds = evo_seconds(ctx, param, value)
    return "frozen" if seconds is None and value is not None else seconds


@contextmanager
def _dask_client(scheduler, workers: int):
    """None (both passes in this process), a Client of the scheduler or of a LocalCluster of ``workers`` ('local')."""
    if scheduler is None:
        yield None
        return
    from distributed import Client

    from turbgen.runs.mann_outofcore import local_cluster

    if scheduler == "local":
        with local_cluster(workers) as cluster, Client(cluster) as client:
            yield client
    else:
        with Client(scheduler) as client:
            yield client


@click.command()
@fft_backend_option
@click.option("--L", "L", type=float, help=f"Length scale L [m] (default {D['length_scale_m']:g}).")
@click.option("--gamma", type=float, help=f"Shear anisotropy Gamma [-] (default {D['gamma']:g}).")
@click.option("--evo", callback=_evo, help=f"Evolution time gamma [s] of tau_e (Eq. 15), or 'frozen' "
              f"(default {D['evo_time_s']:g}).")  # fmt: skip
@click.option("--U", "U", type=float, help=f"Mean wind speed [m/s] (default {D['U_m_s']:g}).")
@click.option("--ae", type=float, help="alpha*eps^(2/3) [m^(4/3)/s^2] (default: the value giving the IEC class A "
              "NTM sigma_1 = 0.16 (0.75 U + 5.6) as model sigma_u).")  # fmt: skip
@click.option("--sigma-u", "sigma_u", type=float, help="Set ae so the model sigma_u is this [m/s].")
@click.option("--ti", type=float, help="Set ae so the model sigma_u is ti * U (ti as a fraction, e.g. 0.18).")
@grid_options(G)
@click.option("--lifetime", type=click.Choice(LIFETIMES), help="Eddy lifetime: guo (Eq. 6, default) or mann (Eq. 4).")
@click.option("--factor1", type=float, help="Guo lifetime small-k slope -factor1 (default 1; stable preset 0.8).")
@click.option("--factor2", type=float, help="tau_e large-k slope -(2/3) factor2 (default 3.5 = Eq. 15).")
@click.option("--pad-yz", "pad_yz", type=int, help=f"Synthesise a box this many times wider in y and z and crop "
              f"(default {D['pad_yz']}; 1 = periodic output, larger = less periodicity, more memory/time).")  # fmt: skip
@click.option("--preset", help="Stability preset (unstable, neutral, stable, or from --presets-file): sets L, Gamma, "
              "gamma, factor1, lifetime and the IEC class; typed options override it.")  # fmt: skip
@click.option("--presets-file", type=click.Path(dir_okay=False), help="User presets (TOML or JSON).")
@click.option("--seed", type=int, help=f"Random seed >= 0 (default {D['seed']}).")
@click.option("--hub-height", "hub_height", type=float, help=f"Hub height [m] (default {D['hub_height_m']:g}).")
@click.option("--out", type=click.Path(), help="Output store (default mann_U<U>_L<L>_G<Gamma>_evo<gamma>_s<seed>.zarr, plus "
              "_p<digest> when other parameters differ from the defaults, and _c<digest of the data> when "
              "constrained).")
@click.option("--chunks", type=int, help="Time samples per store chunk (default min(nt, 1024)); never changes the field.")
@click.option("--overwrite", is_flag=True, help="Replace an existing store.")
@click.option("--config", type=click.Path(dir_okay=False), help="JSON/TOML run file (schemas/mann-run.schema.json); "
              "options typed on the command line override it.")  # fmt: skip
@click.option("--threads", type=click.IntRange(min=1, max=LIMITS["threads"]), help="Worker threads (default: all cores); never changes the field.")
@click.option("--stencil-cache", type=click.Path(file_okay=False),
              help="Directory caching the stencil per parameter set and grid, and with --constrain the system of the "
              "measurements (reused by later seeds).")
@click.option("--memory", help="Memory budget, e.g. 256MiB, 4GiB (default: the available memory). A field whose "
              "snapshot does not fit is made out of core, in two passes through scratch files next to --out "
              "(the same field).")  # fmt: skip
@click.option("--scheduler", help="Out-of-core runs only: dask scheduler address whose workers make the passes "
              "(they must see --out's directory; --memory then holds per worker), or 'local' for a LocalCluster "
              "of --threads single-threaded workers sharing --memory with this process.")  # fmt: skip
@constraint_options(", a `turbgen lidar --out` dataset or a line-of-sight CSV file", "")
@click.option("--fit", "fit", is_flag=True,
              help="With --constrain of point-series files or one lidar record: replay it. L, Gamma, ae, the "
              "evolution time (sensors along x) and the mean wind (power law, veer) are fitted to the data first "
              "(turbgen fit mann) and the field is conditioned with them; --L, --gamma (held for a lidar record), "
              "--ae, --sigma-u, --ti are refused. The store records the fit; turbgen export uses its mean "
              "wind.")  # fmt: skip
def mann(**opt):
    """Mann space-time 4D field: yz-planes at the rotor and range gates, evolving with upstream distance."""
    typed_energy = [name for name in _ENERGY if opt[name] is not None]
    if len(typed_energy) > 1:
        raise click.UsageError(f"give one of --ae, --sigma-u, --ti (got {', '.join(typed_energy)})")
    if opt["presets_file"] and opt["preset"] is None:
        raise click.UsageError("--presets-file needs --preset")
    plane_positions(opt["planes"], opt["gates"])  # --planes and --gates: a usage error
    from turbgen.spec.run_mapping import mann_run_mapping

    # the run as turbgen.mann makes it; --constrain/--noise/--conditional-mean or the run file's (a bad value is
    # refused here, before the run's imports)
    mapping, request = mann_run_mapping({name: opt[name] for name in RUN_OPTIONS}, opt["config"], opt["preset"],
                                        opt["presets_file"])  # fmt: skip
    run = MannRun.from_mapping(mapping) if request is None else None
    with run_imports():
        from turbgen.api.fields import constrained_mann_run
        from turbgen.runs.mann import describe, run_mann
        from turbgen.runs.mann_outofcore import plan_for_budget, remove_stale_scratch
        from turbgen.store.paths import check_output_path
        from turbgen.store.writer import check_new_store

    constraints = out = fit = None
    if request is not None:
        from turbgen.runs.constrain import constrained_store_name

        # no ae, sigma_u, ti or IEC class given: ae estimated from the data (printed with the run below)
        run, constraints, placed, fit = constrained_mann_run(mapping, request, opt, opt["stencil_cache"])
        out = constrained_store_name(run, placed, request.conditional_mean)
    out = opt["out"] if opt["out"] is not None else out or run.default_store_name()
    check_output_path(out)
    threads = default_threads(opt["threads"])
    budget = parse_size(opt["memory"], "--memory") if opt["memory"] is not None else resources.available_memory_bytes()
    # a budget too small fails here, before any output
    plan = plan_for_budget(run, budget, threads, opt["chunks"], opt["scheduler"], opt["stencil_cache"] is None)
    if constraints is not None and (plan is not None or opt["scheduler"] is not None):
        raise click.UsageError("--constrain: constrained fields are made in one pass in memory; this field needs "
                               "an out-of-core run (--memory/--scheduler), which cannot take constraints")
    if opt["scheduler"] not in (None, "local"):  # one line within seconds, not dask's traceback after 30 s
        from turbgen.sweep.scheduler import check_scheduler_address

        check_scheduler_address(opt["scheduler"], connect=plan is not None)
    stale = remove_stale_scratch(out)  # first: the disk check counts the space it held
    # the store's checks (existing output, chunks, disk with the out-of-core scratch) before anything is printed
    check_new_store(out, run.grid, chunk_t=opt["chunks"], overwrite=opt["overwrite"],
                    scratch_bytes=0 if plan is None else plan.scratch_bytes())
    click.echo("turbgen mann")
    for line in describe(run, out, threads):
        click.echo(f"  {line}")
    if fit is not None:
        from turbgen.runs.replay import describe_fit

        click.echo("\n".join(f"  {line}" for line in describe_fit(fit)))
    if run.ae_from.startswith("estimated"):
        click.echo("  sigma_u: none of --ae, --sigma-u, --ti or an IEC class given, so the energy level was "
                   "estimated from the constraint data (see ae above)")
    if plan is None and opt["scheduler"] is not None:
        click.echo(f"  --scheduler {opt['scheduler']} not used: the field fits the memory budget in one pass")
    for path in stale:
        click.echo(f"  removed {path.name}: scratch of a run that was killed")
    if plan is not None:
        from turbgen.runs.mann_outofcore import run_mann_outofcore

        click.echo(f"  {plan.describe()}")
        with _dask_client(opt["scheduler"], threads) as client:
            s = run_mann_outofcore(run, out, memory_bytes=plan.memory_bytes, overwrite=opt["overwrite"],
                                   chunk_t=opt["chunks"], progress=sys.stderr.isatty(), threads=plan.threads,
                                   plan=plan, client=client)  # fmt: skip
    elif constraints is not None:
        from turbgen.runs.constrain import describe_constraints, run_mann_constrained

        s = run_mann_constrained(run, out, constraints, noise_m_s=request.noise_m_s,
                                 conditional_mean=request.conditional_mean,
                                 overwrite=opt["overwrite"], chunk_t=opt["chunks"], threads=threads,
                                 cache_dir=opt["stencil_cache"], progress=sys.stderr.isatty(),
                                 placed=placed, fit=fit)  # fmt: skip
        for line in describe_constraints(s["constraints"]):
            click.echo(f"  {line}")
    else:
        s = run_mann(run, out, overwrite=opt["overwrite"], chunk_t=opt["chunks"], progress=sys.stderr.isatty(),
                     threads=threads, cache_dir=opt["stencil_cache"])  # fmt: skip
    click.echo(f"wrote {s['path']} in {s['seconds']:.1f} s: sigma u/v/w {s['sigma_u']:.3f}/{s['sigma_v']:.3f}/"
               f"{s['sigma_w']:.3f} m/s")  # fmt: skip
