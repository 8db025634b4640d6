"""The ASGI application of `turbgen serve` (FastAPI: typed routes and OpenAPI docs at /docs).

Every path component a client sends is either a run id (24 hex digits, checked before any disk
access) or matched against names the server itself listed; anything else is 404.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
import threading
import zipfile
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse

from turbgen import __version__
from turbgen.errors import ParameterError, TurbgenError
from turbgen.service.catalog import Catalog
from turbgen.service.run_ids import build_run, canonical_mapping, run_id
from turbgen.service.jobs import Jobs, QueueFull
from turbgen.service.limits import (MAX_BODY_BYTES, MAX_JSON_DEPTH, RETRY_AFTER_S, LimitError, check_json_depth,
                                    check_memory, check_token, is_loopback)
from turbgen.service.pages import index_html
from turbgen.store.layout import default_chunk_t, n_chunks

_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")
EXPORT_FORMATS = ("bts", "wnd", "evo", "hawc2", "mt4d", "hdf5")


def _error(status: int, message: str, headers: dict | None = None) -> JSONResponse:
    return JSONResponse({"detail": message}, status_code=status, headers=headers)


def _not_found() -> JSONResponse:
    return _error(404, "no such run or file")


async def _read_json(request: Request):
    """The request body as JSON, at most MAX_BODY_BYTES (LimitError 413 / 415 / 422 otherwise).

    Only ``Content-Type: application/json``: any web page a user of a token-less loopback server visits
    can POST a form or a no-cors fetch (text/plain, form encodings) to it without a CORS preflight, so
    accepting those would let other sites queue and compute runs; a JSON body needs the preflight,
    which this server never grants.
    """
    media = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if media != "application/json":
        raise LimitError(415, f"request body: Content-Type must be application/json, not {media or 'missing'!r}")
    length = request.headers.get("content-length")
    if length is not None and (not length.isdigit() or int(length) > MAX_BODY_BYTES):
        raise LimitError(413, f"request body over {MAX_BODY_BYTES} bytes")
    data = bytearray()
    async for chunk in request.stream():
        data += chunk
        if len(data) > MAX_BODY_BYTES:
            raise LimitError(413, f"request body over {MAX_BODY_BYTES} bytes")
    try:
        value = json.loads(data)
    except RecursionError:  # the decoder itself recurses: thousands of nested arrays
        raise LimitError(422, f"request body: arrays and objects nested deeper than {MAX_JSON_DEPTH} levels") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise LimitError(422, f"request body: not valid JSON ({' '.join(str(exc).split())})") from None
    check_json_depth(value)
    return value


def create_app(root: Path, client, *, token: str | None = None, memory_budget: int, max_queue: int,
               loopback_only: bool = False) -> FastAPI:
    """The application over the catalog in ``root`` running jobs on the dask ``client``.

    Parameters
    ----------
    root : Path
        The catalog's root directory (``root/runs`` is created if missing).
    client : distributed.Client
        Client the runs are submitted to.
    token : str, optional
        Bearer token every request must carry (None: open).
    memory_budget : int
        Memory budget of one run [bytes] (larger runs are refused with 413).
    max_queue : int
        Most runs queued or running at once.
    loopback_only : bool, optional
        Answer only requests whose Host header names a loopback address (400 otherwise): a server bound
        to 127.0.0.1 is then out of reach of DNS rebinding (a web page whose own name resolves to
        127.0.0.1 would otherwise be same-origin with it and could submit and delete runs).

    Returns
    -------
    fastapi.FastAPI
        The application (``app.state.jobs`` holds its job queue).
    """
    catalog = Catalog(root)
    jobs = Jobs(catalog, client, max_queue)
    app = FastAPI(title="turbgen serve", version=__version__,
                  description="Turbulence fields on demand: the same runs as `turbgen mann|kaimal`, deduplicated.")
    app.state.jobs = jobs
    locks: dict[str, threading.Lock] = {}
    locks_guard = threading.Lock()

    def lock_for(key: str) -> threading.Lock:
        with locks_guard:
            return locks.setdefault(key, threading.Lock())

    def may_compute(request: Request) -> None:
        """A derived product (export, validation, lidar report) not cached yet is computed only for a request
        with the token (when the server has one): reading what exists stays open, starting work does not."""
        check_token(token, request.headers.get("authorization"))

    if loopback_only:
        @app.middleware("http")
        async def _loopback_host(request: Request, call_next):
            host = request.headers.get("host", "")
            name = host[1:host.find("]")] if host.startswith("[") else host.rsplit(":", 1)[0]
            if not is_loopback(name.lower()):  # host names are case-insensitive
                return _error(400, f"Host {host!r} is not a loopback name of this server")
            return await call_next(request)

    @app.exception_handler(RequestValidationError)
    async def _invalid(request, exc: RequestValidationError):
        # FastAPI's own check of query and path parameters (e.g. ?U=fast): one line as every other error, not
        # its list of objects (the page showed "[object Object]")
        parts = [f"{'.'.join(str(x) for x in e.get('loc', ()))}: {e.get('msg', 'invalid')}" for e in exc.errors()]
        return _error(422, "; ".join(parts) or "invalid request")

    @app.exception_handler(LimitError)
    async def _limit(request, exc: LimitError):
        return _error(exc.status, str(exc), exc.headers)

    @app.exception_handler(TurbgenError)
    async def _param(request, exc: TurbgenError):
        return _error(422, str(exc))

    def status(rid: str) -> dict:
        req = catalog.request(rid)
        grid = req["run"]["grid"]
        out = {"id": rid, "model": req["model"], "parameters": {k: v for k, v in req["run"].items() if k != "grid"},
               "grid": grid, "preset": req.get("preset"), "turbgen": req.get("turbgen")}  # fmt: skip
        total = 3 * n_chunks(_GridShape(grid), default_chunk_t(grid["nt"]))
        if catalog.is_complete(rid):
            out["status"] = "complete"
            out["progress"] = {"chunks_done": total, "chunks_total": total}
            try:
                out["summary"] = json.loads((catalog.run_dir(rid) / "summary.json").read_text())
            except (OSError, ValueError):
                pass
            rep = catalog.run_dir(rid) / "validation" / "report.json"
            if rep.is_file():
                out["validation"] = {"passed": json.loads(rep.read_text()).get("passed")}
        elif jobs.is_active(rid):
            done = catalog.progress(rid, total)
            out["status"] = "running" if done or _has_temp(catalog, rid) else "queued"
            out["progress"] = {"chunks_done": done, "chunks_total": total}
        else:
            reason = catalog.failure(rid)
            out["status"] = "failed" if reason else "interrupted"
            out["error"] = reason
        return out

    @app.get("/", response_class=HTMLResponse, include_in_schema=False)
    def index():
        return HTMLResponse(index_html(token_required=token is not None))

    @app.get("/health")
    def health():
        with jobs.lock:
            active = len(jobs.active)
        return {"ok": True, "turbgen": __version__, "active": active, "computations": jobs.computations}

    @app.post("/runs", status_code=202)
    async def submit(request: Request):
        """Submit a run config (the JSON `turbgen mann|kaimal --config` takes, plus "model" and "preset")."""
        check_token(token, request.headers.get("authorization"))
        body = await _read_json(request)
        model, run = build_run(body)
        preset = body.get("preset") if isinstance(body, dict) else None
        rid = run_id(model, canonical_mapping(run))
        if not catalog.is_complete(rid):  # a complete run is served, never recomputed
            check_memory(model, run, memory_budget)
        try:
            state = jobs.submit(rid, model, run, preset)
        except QueueFull as exc:
            return _error(429, str(exc), {"Retry-After": str(RETRY_AFTER_S)})
        code = 200 if state == "complete" else 202
        return JSONResponse({"id": rid, "submitted": state, **_links(rid)}, status_code=code)

    @app.get("/runs")
    def list_runs(model: str | None = None, preset: str | None = None, U: float | None = None,
                  seed: int | None = None):
        """The catalog, optionally filtered by model, preset (as submitted), U [m/s] and seed."""
        rows = []
        for rid in catalog.ids():
            try:
                s = status(rid)
            except (OSError, ValueError, KeyError):
                continue
            p = s["parameters"]
            wanted = ((model is None or s["model"] == model) and (preset is None or s["preset"] == preset)
                      and (U is None or p.get("U_m_s") == U) and (seed is None or p.get("seed") == seed))
            if not wanted:
                continue
            rows.append({k: s.get(k) for k in ("id", "model", "status", "progress", "error")} |
                        {"preset": s["preset"], "U_m_s": p.get("U_m_s"), "seed": p.get("seed")})  # fmt: skip
        return {"runs": rows}

    @app.get("/runs/{rid}")
    def get_run(rid: str):
        if not catalog.exists(rid):
            return _not_found()
        return status(rid)

    @app.delete("/runs/{rid}")
    def delete_run(rid: str, request: Request):
        check_token(token, request.headers.get("authorization"))
        if not catalog.exists(rid):
            return _not_found()
        if jobs.is_active(rid):
            return _error(409, "the run is queued or running; delete it once it has finished")
        with lock_for(rid):
            catalog.delete(rid)
        return {"id": rid, "deleted": True}

    @app.post("/sweeps", status_code=202)
    async def sweeps(request: Request):
        """Submit a sweep config (schemas/sweep.schema.json; 'out' is ignored): the run ids."""
        check_token(token, request.headers.get("authorization"))
        body = await _read_json(request)
        if not isinstance(body, dict):
            raise ParameterError("request body: expected a JSON object with the sweep config")
        from turbgen.sweep.plan_file import plan_from_mapping

        # keys of `turbgen sweep` files the service does not take: a server file, a network address, a path or a
        # worker count named by the client (refused rather than silently ignored)
        refused = {"preset_file": "give user_presets inline", "lidar": "GET /runs/<id>/lidar?lidar=PRESET per run",
                   "scheduler": "the server's own cluster runs every run", "workers": "the server's own cluster runs "
                   "every run", "out": "runs are stored in the server's catalog: GET /runs/<id>/store"}  # fmt: skip
        for key, instead in refused.items():
            if key in body:
                raise ParameterError(f"{key}: not accepted by the service ({instead})")
        plan = plan_from_mapping({**body, "out": "unused"})
        rids = [run_id(pr.model, canonical_mapping(pr.run)) for pr in plan.runs]
        new = [pr for pr, rid in zip(plan.runs, rids) if not catalog.is_complete(rid)]  # complete runs are served
        for pr in new:
            check_memory(pr.model, pr.run, memory_budget)
        ids = []
        with jobs.lock:
            free = jobs.max_queue - len(jobs.active)
        if len(new) > free:
            return _error(429, f"the sweep has {len(new)} runs to compute, the queue has room for {free}",
                          {"Retry-After": str(RETRY_AFTER_S)})  # fmt: skip
        for pr, rid in zip(plan.runs, rids):
            try:
                jobs.submit(rid, pr.model, pr.run, pr.preset)
            except QueueFull as exc:
                return _error(429, str(exc), {"Retry-After": str(RETRY_AFTER_S)})
            ids.append({"id": rid, "model": pr.model, "preset": pr.preset, "U_m_s": pr.U_m_s, "seed": pr.seed})
        return {"runs": ids}

    def complete_store(rid: str) -> Path | None:
        if not catalog.exists(rid) or not catalog.is_complete(rid):
            return None
        return catalog.store_path(rid)

    @app.api_route("/runs/{rid}/store/{path:path}", methods=["GET", "HEAD"])
    def store_file(rid: str, path: str):
        """Read-only zarr access: xr.open_zarr("http://host:port/runs/<id>/store")."""
        store = complete_store(rid)
        if store is None:
            return _not_found()
        parts = path.split("/")
        if not all(_NAME.match(p) for p in parts):
            return _not_found()
        target = store.joinpath(*parts)
        try:
            target.resolve().relative_to(store.resolve())
        except ValueError:
            return _not_found()
        if not target.is_file():
            return _not_found()
        return FileResponse(target, media_type="application/octet-stream")

    @app.get("/runs/{rid}/export")
    def export(rid: str, format: str, http: Request, plane: int | None = None):
        """The store exported (made on first request, cached); several files come as one .zip."""
        store = complete_store(rid)
        if store is None:
            return _not_found()
        if format not in EXPORT_FORMATS:
            raise ParameterError(f"format: {format!r} is not one of {', '.join(EXPORT_FORMATS)}")
        from turbgen.export import ExportRequest, export_store

        request = ExportRequest(plane=plane, source_label=f"/runs/{rid}/store")  # not the catalog's path here
        key = format if plane is None else f"{format}-plane{plane}"
        final = catalog.run_dir(rid) / "exports" / key
        with lock_for(f"{rid}/export/{key}"):
            if not final.is_dir():
                may_compute(http)
                final.parent.mkdir(exist_ok=True)
                tmp = Path(tempfile.mkdtemp(dir=final.parent, prefix=".tmp-"))
                try:
                    name = f"{rid}.{format}" if format in ("bts", "hdf5") else rid
                    result = export_store(store, format, tmp / name, request)
                    files = sorted(Path(p) for p in result.paths)
                    if len(files) > 1:
                        with zipfile.ZipFile(tmp / f"{rid}-{format}.zip", "w") as z:
                            for f in files:
                                z.write(f, f.name)
                        for f in files:
                            f.unlink()
                    os.replace(tmp, final)
                except BaseException:
                    shutil.rmtree(tmp, ignore_errors=True)
                    raise
        (single,) = [p for p in final.iterdir() if not p.name.startswith(".")]
        return FileResponse(single, filename=single.name, media_type="application/octet-stream")

    def validation_dir(rid: str, store: Path, request: Request) -> Path:
        final = catalog.run_dir(rid) / "validation"
        with lock_for(f"{rid}/validation"):
            if not (final / "report.json").is_file():
                may_compute(request)
                from turbgen.validate import validate

                tmp = Path(tempfile.mkdtemp(dir=final.parent, prefix=".tmp-validation-"))
                try:
                    rep = validate(store)
                    rep.plots(tmp / "plots")
                    (tmp / "report.json").write_text(json.dumps(rep.to_dict(), indent=1))
                    shutil.rmtree(final, ignore_errors=True)
                    os.replace(tmp, final)
                except BaseException:
                    shutil.rmtree(tmp, ignore_errors=True)
                    raise
        return final

    @app.get("/runs/{rid}/validation")
    def validation(rid: str, request: Request):
        """The `turbgen validate --json` report (computed once, cached), with the names of its PNG plots."""
        store = complete_store(rid)
        if store is None:
            return _not_found()
        d = validation_dir(rid, store, request)
        report = json.loads((d / "report.json").read_text())
        report["store"] = f"/runs/{rid}/store"  # the server's paths stay private
        plots = sorted(p.name for p in (d / "plots").glob("*.png"))
        return {"id": rid, "report": report, "plots": [f"/runs/{rid}/plots/{p}" for p in plots]}

    @app.get("/runs/{rid}/lidar")
    def lidar(rid: str, request: Request, lidar: str = "nacelle-4beam"):
        """`turbgen lidar --json` on the run's store for a lidar *preset* (computed once per preset, cached)."""
        from turbgen.lidar.description import PRESETS
        from turbgen.lidar.report import lidar_report
        from turbgen.store import open_store

        store = complete_store(rid)
        if store is None:
            return _not_found()
        if lidar not in PRESETS:  # presets only: no client-supplied file path reaches the filesystem
            return _error(422, f"lidar = {lidar!r} is not one of {', '.join(PRESETS)}")
        final = catalog.run_dir(rid) / "lidar" / f"{lidar}.json"
        with lock_for(f"{rid}/lidar/{lidar}"):
            if not final.is_file():
                may_compute(request)
                try:
                    report = lidar_report(open_store(store), lidar).to_dict()
                except TurbgenError as exc:
                    return _error(422, str(exc).replace(str(store), f"/runs/{rid}/store"))
                report["store"] = f"/runs/{rid}/store"  # the server's paths stay private
                final.parent.mkdir(exist_ok=True)
                tmp = final.with_name(f".{final.name}.tmp-{os.getpid()}")
                tmp.write_text(json.dumps(report, default=float))
                os.replace(tmp, final)
        return {"id": rid, "lidar": lidar, "report": json.loads(final.read_text())}

    @app.get("/runs/{rid}/plots/{name}")
    def plot(rid: str, name: str, request: Request):
        store = complete_store(rid)
        if store is None or not _NAME.match(name) or not name.endswith(".png"):
            return _not_found()
        d = validation_dir(rid, store, request) / "plots"
        if name not in {p.name for p in d.glob("*.png")}:
            return _not_found()
        return FileResponse(d / name, media_type="image/png")

    return app


class _GridShape:
    """The two grid fields n_chunks reads (nt, nx), from a grid mapping."""

    def __init__(self, grid: dict):
        self.nt = grid["nt"]
        self.nx = len(grid["x_m"])


def _has_temp(catalog: Catalog, rid: str) -> bool:
    from turbgen.store.temporaries import temp_prefix

    prefix = temp_prefix(catalog.store_path(rid))
    return any(p.name.startswith(prefix) for p in catalog.run_dir(rid).iterdir())


def _links(rid: str) -> dict:
    return {"status_url": f"/runs/{rid}", "store_url": f"/runs/{rid}/store"}
