"""`turbgen <model>` of a declared model without a command of its own (turbgen.spec.models, ``command`` None).

One option per entry of the model's OPTIONS, typed and described by its run schema, plus the grid options, --config,
--out, --overwrite, --chunks and --threads; the inputs merge as the Python API's (turbgen.spec.run_inputs) and the
model's turbgen.runs Model makes the run."""

from __future__ import annotations

import click

from turbgen.cli.options import parse_floats, plane_positions
from turbgen.cli.run_options import fft_backend_option, grid_options
from turbgen.spec.config import load_schema
from turbgen.spec.models import declaration, resolve
from turbgen.spec.run_inputs import GRID_OPTIONS
from turbgen.theory.ranges import LIMITS


def _option(name: str, spec: dict, default) -> click.Option:
    """``--name`` of a run key whose schema is ``spec`` (type, enum, description) and default ``default``."""
    flag, kind = "--" + name.replace("_", "-"), spec.get("type")
    help = spec.get("description", "") + ("" if default is None else f" (default {default})")
    if kind == "boolean":
        return click.option(flag, name, is_flag=True, default=None, help=help)
    if "enum" in spec:
        return click.option(flag, name, type=click.Choice([str(v) for v in spec["enum"]]), help=help)
    if kind == "array":
        return click.option(flag, name, callback=lambda ctx, p, v: None if v is None else parse_floats(v, flag),
                            help=help)
    return click.option(flag, name, type={"integer": int, "number": float}.get(kind, str) if isinstance(kind, str)
                        else str, help=help)


def model_command(name: str) -> click.Command:
    """The click command of model ``name``, built from its declaration."""
    d = declaration(name)
    options, defaults = resolve(d.options, "spec"), resolve(d.defaults, "spec")
    properties = load_schema(d.schema)["properties"]

    def command(**opt):
        from turbgen.runs.models import get_model
        from turbgen.spec.config import read_config
        from turbgen.spec.run_inputs import merge_run_inputs
        from turbgen.spec.run_mapping import run_inputs

        plane_positions(opt["planes"], opt["gates"])  # --planes and --gates: a usage error
        given, grid, x_m = run_inputs(name, {o: opt[o] for o in (*options, *GRID_OPTIONS, "planes", "gates")})
        file_mapping = None if opt["config"] is None else read_config(opt["config"], d.schema)
        model = get_model(name)
        run = model.spec.from_mapping(merge_run_inputs(file_mapping, given, grid, replaces=resolve(d.replaces, "spec"),
                                                       x_m=x_m))  # fmt: skip
        out = opt["out"] or f"{name}_s{run.seed}.zarr"
        s = model.run(run, out, overwrite=opt["overwrite"], chunk_t=opt["chunks"], threads=opt["threads"])
        click.echo(f"wrote {s['path']}")

    command.__doc__ = f"{name} field to a store (options: the {d.schema} schema's keys)."
    for option in reversed((
        *(_option(o, properties[key], defaults.get(key)) for o, key in options.items()),
        grid_options(defaults),
        click.option("--config", type=click.Path(dir_okay=False), help="JSON/TOML run file; options override it."),
        click.option("--out", type=click.Path(), help=f"Output store (default {name}_s<seed>.zarr)."),
        click.option("--overwrite", is_flag=True, help="Replace an existing store."),
        click.option("--chunks", type=int, help="Time samples per store chunk; never changes the field."),
        click.option("--threads", type=click.IntRange(min=1, max=LIMITS["threads"]), help="FFT threads."),
    )):
        command = option(command)
    return click.command(name)(fft_backend_option(command))
