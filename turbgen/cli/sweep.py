"""`turbgen sweep`: many fields (models x presets x speeds x seeds) on dask.distributed."""

from __future__ import annotations

import click

from turbgen.cli.options import (iec_class_options, parse_floats, parse_ints, parse_range, plane_positions, range_help,
                                 resolve_iec_class)
from turbgen.cli.run_options import fft_backend_option


def _split(text: str | None) -> list[str] | None:
    return None if text is None else [t.strip() for t in text.split(",") if t.strip()]


@click.command()
@fft_backend_option
@click.option("--config", "config", type=click.Path(dir_okay=False),
              help="sweep file (TOML or JSON, schemas/sweep.schema.json)")
@click.option("--model", "models", help="mann, kaimal or mann,kaimal")
@click.option("--preset", "presets", help="stability presets, e.g. neutral or unstable,neutral,stable")
@click.option("--speeds", help="hub-height mean wind speeds [m/s], e.g. 12,16 or 12:24:2")
@click.option("--seeds", help="seeds, e.g. 1-21 or 1,4,7")
@click.option("--presets-file", type=click.Path(dir_okay=False), help="user presets (TOML or JSON)")
@click.option("--nt", type=int, help=f"time steps, {range_help('nt')} (default: as turbgen mann / kaimal)")
@click.option("--dt", type=float, help=f"time step [s], {range_help('dt_s')}")
@click.option("--planes", help="plane positions x [m upstream], e.g. 0,50,100")
@click.option("--gates", help="range gates start:stop:step [m]; planes = rotor 0 + gates")
@click.option("--ny", type=int, help=f"lateral points, {range_help('ny')}")
@click.option("--nz", type=int, help=f"vertical points, {range_help('nz')}")
@click.option("--dy", type=float, help=f"lateral spacing [m], {range_help('dy_m')}")
@click.option("--dz", type=float, help=f"vertical spacing [m], {range_help('dz_m')}")
@click.option("--hub-height", type=float, help="hub height [m]")
@click.option("--chunks", type=int, help="time chunk length of the stores")
@click.option("--workers", type=int, help="LocalCluster worker processes (default: one per core)")
@click.option("--scheduler", help="address of an existing dask scheduler (workers must see --out)")
@click.option("--validate/--no-validate", default=None, help="validate every field against theory")
@click.option("--lidar", help="run this lidar (preset or TOML/JSON file, see turbgen lidar) on every field and put "
              "its k_0.5, cut-off and coherence verdict in the manifest")
@click.option("--out", type=click.Path(file_okay=False), help="output directory (stores and manifest)")
@click.option("--dlc", type=click.Choice(["1.1", "1.2", "1.3"]), default=None,
              help="IEC 61400-1 design-load-case set: 1.1/1.2 (NTM) or 1.3 (ETM) at --iec-class, speeds "
                   "--v-in..--v-out in 2 m/s steps, --seeds (default 1-6), one --model (default kaimal); every field is exported to "
                   "OUT/wind/ with its InflowWind input file and listed in OUT/dlc_manifest.csv.")
@iec_class_options("--dlc: turbine class and turbulence category, e.g. IIB.")
@click.option("--v-in", "v_in", type=float, default=4.0, show_default=True, help="--dlc: cut-in speed V_in [m/s].")
@click.option("--v-out", "v_out", type=float, default=24.0, show_default=True, help="--dlc: cut-out speed V_out [m/s].")
@click.option("--export-format", type=click.Choice(["bts", "wnd", "hawc2"]), default="bts", show_default=True,
              help="--dlc: format of the exported wind files.")
@click.option("--memory", help="memory budget of each run, e.g. 4GiB: Mann fields that do not fit are made out of "
              "core (turbgen mann --memory), the same fields")  # fmt: skip
@click.option("--stencil-cache", type=click.Path(file_okay=False),
              help="a sweep with constrain: directory caching the stencil and the system of the measurements, which "
              "its seeds then share (turbgen mann --stencil-cache); the workers must see it at the same path")
def sweep(config, models, presets, speeds, seeds, presets_file, nt, dt, planes, gates, ny, nz, dy, dz, hub_height,
          chunks, workers, scheduler, validate, lidar, out, dlc, iec_class, class_alias, v_in, v_out, export_format,
          memory, stencil_cache):  # fmt: skip
    """Generate every field of a sweep (resumable: complete stores are kept), write DIR/manifest.json/.csv.

    Either --config FILE (command-line --out, --workers, --scheduler, --validate and --chunks override the file) or
    --model, --preset, --speeds, --seeds and --out. Exit code 0 when every run has a complete store (and passed
    validation, with --validate), 1 when some run failed, 3 when all stores are complete but some failed validation or
    the lidar coherence check (see the summary and the manifest)."""
    from turbgen.spec.preset_files import load_presets
    from turbgen.sweep import make_plan, plan_from_file, run_sweep, summary_table
    from turbgen.sweep.plan import check_memory_budget

    grid = {k: v for k, v in dict(nt=nt, dt=dt, ny=ny, nz=nz, dy=dy, dz=dz, hub_height=hub_height).items()
            if v is not None}  # fmt: skip
    x_m = plane_positions(parse_floats(planes, "--planes") if planes is not None else None,
                          parse_range(gates, "--gates") if gates is not None else None)  # fmt: skip
    if x_m is not None:
        grid["planes"] = x_m
    iec_class = resolve_iec_class(iec_class, class_alias, "sweep")
    if dlc is not None:
        given = [n for n, v in [("--config", config), ("--preset", presets), ("--speeds", speeds),
                                ("--presets-file", presets_file), ("--lidar", lidar), ("--memory", memory),
                                ("--validate", validate), ("--stencil-cache", stencil_cache)]
                 if v is not None]  # fmt: skip
        if given or not iec_class or not out or (models is not None and "," in models):
            raise click.UsageError(f"--dlc takes --iec-class, --out and one --model; it sets presets and speeds itself"
                                   f"{' (remove ' + ', '.join(given) + ')' if given else ''}")
        return _run_dlc(dlc, iec_class, v_in, v_out, seeds, (models or "kaimal").strip(), grid, chunks, workers,
                        scheduler, out, export_format)
    if config:
        given = [n for n, v in [("--model", models), ("--preset", presets), ("--speeds", speeds), ("--seeds", seeds),
                                ("--presets-file", presets_file)] if v is not None]  # fmt: skip
        if given or grid:
            raise click.UsageError(f"--config defines the sweep; {', '.join(given + sorted(grid))} cannot be combined")
        plan = plan_from_file(config, out=out, validate=validate, workers=workers, scheduler=scheduler, chunk_t=chunks,
                              lidar=lidar)
    else:
        missing = [n for n, v in [("--model", models), ("--preset", presets), ("--speeds", speeds), ("--seeds", seeds),
                                  ("--out", out)] if v is None]  # fmt: skip
        if missing:
            raise click.UsageError(f"give --config FILE, or --model, --preset, --speeds, --seeds and --out (missing: "
                                   f"{', '.join(missing)})")
        speed_list = parse_range(speeds, "--speeds") if ":" in speeds else parse_floats(speeds, "--speeds")
        plan = make_plan(out=out, models=_split(models), presets=_split(presets), speeds=speed_list,
                         seeds=parse_ints(seeds, "--seeds"), grid=grid, validate=bool(validate), chunk_t=chunks,
                         workers=workers, scheduler=scheduler, lidar=lidar,
                         user_presets=load_presets(presets_file) if presets_file else None)  # fmt: skip
    from turbgen.resources import parse_size

    budget = parse_size(memory, "--memory") if memory is not None else None
    check_memory_budget(plan.runs, budget, plan.chunk_t)  # (run_sweep checks it too) before any line is printed
    if stencil_cache is not None and plan.constraints is None:
        raise click.UsageError("--stencil-cache is for a sweep with constrain (the runs of other sweeps share their "
                               "stencil already)")  # fmt: skip
    result = run_sweep(plan, progress=True, memory_bytes=budget, stencil_cache=stencil_cache)
    click.echo(summary_table(result))
    if not result.ok:
        raise click.exceptions.Exit(1)
    if result.validation_failed or result.lidar_failed:
        raise click.exceptions.Exit(3)


def _run_dlc(dlc, iec_class, v_in, v_out, seeds, model, grid, chunks, workers, scheduler, out, export_format):
    """`turbgen sweep --dlc`: the set's fields, their exports and OUT/dlc_manifest.csv."""
    from turbgen.spec.dlc import DlcSet
    from turbgen.sweep import run_sweep, summary_table
    from turbgen.sweep.dlc import export_dlc, make_dlc_plan

    seed_list = parse_ints(seeds, "--seeds") if seeds is not None else (1, 2, 3, 4, 5, 6)
    dlc_set = DlcSet(dlc, iec_class, v_in, v_out, tuple(seed_list))
    plan = make_dlc_plan(dlc_set, out=out, model=model, grid=grid, chunk_t=chunks, workers=workers,
                         scheduler=scheduler)
    result = run_sweep(plan, progress=True)
    click.echo(summary_table(result))
    manifest = export_dlc(plan, dlc_set, result, export_format)
    click.echo(f"wrote {manifest} ({dlc_set.label}: wind files and InflowWind input files in {plan.out}/wind)")
    click.echo("use: each row's inflowwind_file is the InflowFile of one OpenFAST run (names relative to it)")
    if not result.ok:
        raise click.exceptions.Exit(1)
