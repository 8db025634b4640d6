"""Products derived from a complete run (exports, validation, lidar reports): computed on first request under a
temporary name in ``ROOT/work``, published atomically under the run's directory unless the run was deleted
meanwhile (a DELETE bumps the run's generation), served from there afterwards."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

from fastapi import Request

from turbgen.store.discard import remove_path
from turbgen.service.limits import LimitError
from turbgen.service.state import ServiceState, require_token
from turbgen.store.temporaries import publish, temp_name


def cached_product(state: ServiceState, request: Request, rid: str, final: Path, ready, build) -> Path:
    """``final`` once ``ready(final)``, built by ``build(tmp)`` and published if not (one build per product at a
    time; starting one needs the token). LimitError 401 without it, 503 when too many compute, 404 for a deleted run."""
    if ready(final):
        return final
    generation = state.generation(rid)
    name = "-".join(final.relative_to(state.catalog.run_dir(rid)).parts)
    with state.limiter.admit(), state.lock_for(f"{rid}/{name}"):
        if ready(final):
            return final
        require_token(request, state)
        tmp = temp_name(state.catalog.work / f"{rid}-{name}")
        try:
            try:
                with state.limiter.slot():
                    build(tmp)
            except Exception:
                _raise_if_deleted(state, rid, generation)
                raise
            with state.lock_for(rid):  # DELETE takes it too: the run cannot vanish between this check and the rename
                _raise_if_deleted(state, rid, generation)
                final.parent.mkdir(exist_ok=True)
                old = publish(tmp, final, replace=True)
            if old is not None:
                remove_path(old)
        finally:
            remove_path(tmp)
    return final


def _raise_if_deleted(state: ServiceState, rid: str, generation: int) -> None:
    if state.generation(rid) != generation or not state.catalog.exists(rid):
        raise LimitError(404, "the run was deleted while this was computed")


def build_export(store: Path, rid: str, fmt: str, request, tmp: Path) -> None:
    """Export ``store`` in format ``fmt`` into the new directory ``tmp`` (files named ``rid``; several as a .zip)."""
    from turbgen.exporters import export_store

    tmp.mkdir()
    name = f"{rid}.{fmt}" if fmt in ("bts", "hdf5") else rid
    result = export_store(store, fmt, tmp / name, request)
    files = sorted(Path(p) for p in result.paths)
    if len(files) > 1:
        with zipfile.ZipFile(tmp / f"{rid}-{fmt}.zip", "w") as z:
            for f in files:
                z.write(f, f.name)
        for f in files:
            f.unlink()


def build_validation(store: Path, tmp: Path) -> None:
    """The `turbgen validate` report of ``store`` (report.json) and its PNG plots (plots/) into the new directory ``tmp``."""
    from turbgen.validation import validate

    rep = validate(store)
    tmp.mkdir()
    rep.plots(tmp / "plots")
    (tmp / "report.json").write_text(json.dumps(rep.to_dict(), indent=1))


def build_lidar(store: Path, rid: str, lidar, tmp: Path) -> None:
    """`turbgen lidar --json` of ``store`` into the new file ``tmp`` (``lidar``: a preset or a description)."""
    from turbgen.virtual_lidar.report import lidar_report
    from turbgen.store import open_store

    report = lidar_report(open_store(store), lidar).to_dict()
    report["store"] = f"/runs/{rid}/store"  # the server's paths stay private
    tmp.write_text(json.dumps(report, default=float))
