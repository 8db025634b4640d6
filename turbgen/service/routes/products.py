"""Routes of products derived from a complete run: exports, the validation report and plots, lidar reports."""

from __future__ import annotations

import hashlib
import json
from functools import partial
from pathlib import Path

from fastapi import APIRouter, Depends, Request
from fastapi.responses import FileResponse
from starlette.concurrency import run_in_threadpool

from turbgen.errors import ParameterError
from turbgen.service.bodies import read_json
from turbgen.service.derived import build_export, build_lidar, build_validation, cached_product
from turbgen.service.limits import LimitError
from turbgen.service.routes.runs import NAME
from turbgen.service.state import ServiceState, complete_store, get_state, not_found, require_token

router = APIRouter()
EXPORT_FORMATS = ("bts", "wnd", "evo", "hawc2", "mt4d", "hdf5")


@router.get("/runs/{rid}/export")
def export(rid: str, format: str, http: Request, plane: int | None = None, drop_below_ground: bool = False,
           hub_height: float | None = None, shear_exponent: float | None = None, profile: str | None = None,
           veer: float | None = None, mean_history: str | None = None, transient: str | None = None,
           iec_class: str | None = None, rotor_diameter: float | None = None, transient_start: float = 10.0,
           transient_sign: str = "+", tower: bool = False, periodic: bool = True, runner_files: bool = False,
           store: Path = Depends(complete_store), state: ServiceState = Depends(get_state)):  # fmt: skip
    """The store exported (made on first request, cached); several files come as one .zip.

    The keys are `turbgen export`'s options (the same checks, one mean-wind definition; a bad value is a 422):
    ``drop_below_ground`` drops the grid rows at or below the ground (a run with a low hub height; without it such a
    run is refused), ``hub_height`` [m], ``shear_exponent``, ``profile`` (``power:ALPHA``, ``log:z0=Z0[,d=D]`` or
    ``table:z,U[,dir];z,U[,dir];...``: the table's rows inline), ``veer`` [deg/m], ``mean_history``
    (``t,U[,dir];...`` inline), ``transient`` (EOG, EDC, ECD, EWS-V, EWS-H) with ``iec_class``, ``rotor_diameter``
    [m], ``transient_start`` [s], ``transient_sign`` (+/-), ``tower``, ``periodic``, ``runner_files`` (the
    InflowWind input file and HAWC2 block in the .zip; default false)."""
    if format not in EXPORT_FORMATS:
        raise ParameterError(f"format: {format!r} is not one of {', '.join(EXPORT_FORMATS)}")
    if format == "evo" and runner_files:  # its LidarSim section names the .evo by an absolute path on this server
        raise ParameterError("runner_files: the evo export's LidarSim section holds the .evo's absolute path, which "
                             "the service does not reveal; export evo without runner_files and point the section "
                             "at your copy (see `turbgen export --format evo`)")  # fmt: skip
    from turbgen.exporters.options import ExportOptions, export_request

    opts = ExportOptions(plane=plane, hub_height_m=hub_height, shear_exponent=shear_exponent, profile=profile,
                         veer_deg_per_m=veer, mean_history=mean_history, transient=transient, iec_class=iec_class,
                         rotor_diameter_m=rotor_diameter, transient_start_s=transient_start,
                         transient_sign=transient_sign, tower=tower, periodic=periodic,
                         drop_below_ground=drop_below_ground, runner_files=runner_files)
    request = export_request(store, format, opts, inline=True,
                             source_label=f"/runs/{rid}/store")  # not the catalog's path here  # fmt: skip
    final = state.catalog.run_dir(rid) / "exports" / _export_key(format, opts)
    cached_product(state, http, rid, final, Path.is_dir, partial(build_export, store, rid, format, request))
    (single,) = [p for p in final.iterdir() if not p.name.startswith(".")]
    return FileResponse(single, filename=single.name, media_type="application/octet-stream")


def _export_key(fmt: str, opts) -> str:
    """The cached export's folder name: format, plane, above-ground, then a digest of any other option given."""
    other = {k: v for k, v in opts.given().items() if k not in ("plane", "drop_below_ground", "runner_files")}
    if opts.runner_files:  # the service's default is False (the command line's True)
        other["runner_files"] = True
    digest = hashlib.sha256(json.dumps(other, sort_keys=True).encode()).hexdigest()[:12] if other else ""
    return (fmt + ("" if opts.plane is None else f"-plane{opts.plane}")
            + ("-above-ground" if opts.drop_below_ground else "") + (f"-o{digest}" if digest else ""))


def _validation_dir(state: ServiceState, request: Request, rid: str, store: Path) -> Path:
    final = state.catalog.run_dir(rid) / "validation"
    return cached_product(state, request, rid, final, lambda d: (d / "report.json").is_file(),
                          partial(build_validation, store))  # fmt: skip


@router.get("/runs/{rid}/validation")
def validation(rid: str, request: Request, store: Path = Depends(complete_store),
               state: ServiceState = Depends(get_state)):  # fmt: skip
    """The `turbgen validate --json` report (computed once, cached), with the names of its PNG plots."""
    d = _validation_dir(state, request, rid, store)
    report = json.loads((d / "report.json").read_text())
    report["store"] = f"/runs/{rid}/store"  # the server's paths stay private
    plots = sorted(p.name for p in (d / "plots").glob("*.png"))
    return {"id": rid, "report": report, "plots": [f"/runs/{rid}/plots/{p}" for p in plots]}


@router.get("/runs/{rid}/lidar")
def lidar(rid: str, request: Request, lidar: str = "nacelle-4beam", store: Path = Depends(complete_store),
          state: ServiceState = Depends(get_state)):  # fmt: skip
    """`turbgen lidar --json` on the run's store for a lidar *preset* (computed once per preset, cached)."""
    from turbgen.virtual_lidar.description import PRESETS

    if lidar not in PRESETS:  # presets only: no client-supplied file path reaches the filesystem
        raise LimitError(422, f"lidar = {lidar!r} is not one of {', '.join(PRESETS)}")
    final = state.catalog.run_dir(rid) / "lidar" / f"{lidar}.json"
    cached_product(state, request, rid, final, Path.is_file, partial(build_lidar, store, rid, lidar))  # paths in a
    # refusal (TurbgenError, 422) are shown as URLs by the application's handler
    return {"id": rid, "lidar": lidar, "report": json.loads(final.read_text())}


@router.post("/runs/{rid}/lidar", dependencies=[Depends(require_token)])
async def lidar_file(rid: str, request: Request, store: Path = Depends(complete_store),
                     state: ServiceState = Depends(get_state)):  # fmt: skip
    """`turbgen lidar --json` on the run's store for the lidar a client describes: the body is the content of a
    lidar file (JSON, schemas/lidar.schema.json); computed once per description, cached."""
    from turbgen.virtual_lidar.description import lidar_from_mapping

    body = await read_json(request)
    if not isinstance(body, dict):
        raise ParameterError("request body: expected a JSON object with the lidar description")
    description = lidar_from_mapping(body, where="lidar file")
    digest = hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()[:24]
    final = state.catalog.run_dir(rid) / "lidar" / f"file-{digest}.json"
    await run_in_threadpool(cached_product, state, request, rid, final, Path.is_file,
                            partial(build_lidar, store, rid, description))  # fmt: skip
    return {"id": rid, "lidar": description.name, "report": json.loads(final.read_text())}


@router.get("/runs/{rid}/plots/{name}")
def plot(rid: str, name: str, request: Request, state: ServiceState = Depends(get_state)):
    """One PNG plot of the run's validation (the validation is computed first if needed)."""
    if not NAME.match(name) or not name.endswith(".png"):
        raise not_found()
    store = complete_store(rid, state)
    d = _validation_dir(state, request, rid, store) / "plots"
    if name not in {p.name for p in d.glob("*.png")}:
        raise not_found()
    return FileResponse(d / name, media_type="image/png")
