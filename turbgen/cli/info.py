"""`turbgen info STORE`: a readable summary of a field store (or `--json`)."""

from __future__ import annotations

import json
from pathlib import Path

import click

from turbgen.cli import run_imports
from turbgen.resources import format_bytes


def _value(v) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, list):
        return ", ".join(_value(x) for x in v)
    if isinstance(v, dict) and len(v.get("f_hz") or ()) > 8:  # a user spectrum's table (turbgen.theory.user_spectra)
        return f"table of {', '.join(v)} on {len(v['f_hz'])} lines, {v['f_hz'][0]:g} to {v['f_hz'][-1]:g} Hz"
    if isinstance(v, dict):
        return json.dumps(v)
    return str(v)


def _unit(u: str) -> str:
    return "" if u in ("", "1", "-") else f" {u}"


def _lines(s: dict) -> list[str]:
    g = s["grid"]
    decoded = "every chunk decoded" if s.get("chunks_decoded") else "chunks not decoded (large store: validate reads them)"
    rows = [
        ("store", s["path"]),
        ("status", f"complete, {format_bytes(s['size_on_disk_bytes'])} on disk "
                   f"({format_bytes(s['size_uncompressed_bytes'])} uncompressed), {decoded}"),
        ("model", f"{s['model']}, seed {s['seed']}"),
        ("created", f"{s['created_utc']} by turbgen {s['turbgen_version']}"
                    + (f", FFT backend {s['fft_backend']}" if s.get("fft_backend") else "")),
        ("grid", f"(t, x, y, z) = {' x '.join(map(str, s['shape_t_x_y_z']))}, u v w float32, "
                 f"time chunks of {s['chunk_t']}"),
        ("time", f"dt {g['dt_s']:g} s, duration {s['duration_s']:g} s"),
        ("planes", f"{len(g['x_m'])}: x = {_value(g['x_m'])} m upstream of the rotor"),
        ("y, z", f"dy {g['dy_m']:g} m, dz {g['dz_m']:g} m; points span {s['width_y_m']:g} m (y) x "
                 f"{s['height_z_m']:g} m (z), centred on the hub"),
        ("wind", f"U {s['U_m_s']:g} m/s, hub height {s['hub_height_m']:g} m"),
        ("frame", f"{s['frame']}: {s['frame_note']}"),
    ]  # fmt: skip
    width = max(len(k) for k, _ in rows)
    out = [f"{k:<{width}}  {v}" for k, v in rows]
    out.append("parameters")
    units = s["units"]
    pw = max((len(k) for k in s["parameters"]), default=0)
    out += [f"  {k:<{pw}}  {_value(v)}{_unit(units.get(k, ''))}" for k, v in s["parameters"].items()]
    c = s.get("constraints")
    if c is not None:
        solver = c["solver"]
        out.append(f"constraints  {'conditional mean' if c['conditional_mean'] else 'conditional sample'} on "
                   f"{len(c['series'])} series, {c['n_samples']} samples ({', '.join(c['files'])}); solve "
                   f"{solver['method']}, {solver['iterations']} iterations, relative residual "
                   f"{solver['relative_residual']:.1e}; field - data max {c['residual_max_m_s']:.2e} m/s")  # fmt: skip
        out += [f"  {m['name']}: x {m['x_m']:g} m, y {m['y_m']:g} m, z {m['z_m']:g} m, noise {m['noise_m_s']:g} m/s"
                for m in c["series"]]
    if "fit" in s:
        from turbgen.runs.replay import describe_fit

        out += [f"fit  {line}" for line in describe_fit(s["fit"])]
    out += [f"warning  {w}" for w in s.get("warnings", [])]
    return out


@click.command()
@click.argument("store", type=click.Path(path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON (units in the key names).")
def info(store: str, as_json: bool):
    """Summarise the field store STORE: model, grid, planes, dt, U, seed, parameters, size, completeness.

    STORE may also be an exported .bts, InflowWind input file (.dat) or .sum: its header, title and
    description are printed (the mean wind the export added, a non-periodic file's start shift).

    A missing, incomplete or corrupted store (a chunk that does not decode or holds NaN; every
    chunk is decoded for stores up to 256 MiB) is reported in one line (exit code 2). Temporaries
    left beside STORE (or inside it, for a sweep directory) by killed writers are removed."""
    path = Path(store).expanduser().absolute()
    if path.is_file():
        from turbgen.exporters.describe import file_summary

        rows = file_summary(path)
        width = max(len(k) for k, _ in rows)
        click.echo(json.dumps(dict(rows), indent=2) if as_json else "\n".join(f"{k:<{width}}  {v}" for k, v in rows))
        return
    with run_imports():
        from turbgen.api.products import info as store_info
        from turbgen.store.temporaries import remove_dead_temporaries, report_removed
    report_removed(remove_dead_temporaries(path.parent, [path.name]))
    if path.is_dir() and not (path / "zarr.json").is_file():
        report_removed(remove_dead_temporaries(path))  # e.g. a sweep directory
    summary = store_info(path)
    click.echo(json.dumps(summary, indent=2) if as_json else "\n".join(_lines(summary)))
