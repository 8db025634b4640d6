"""Products derived from a complete run (exports, validation report and plots, lidar reports): computed on first
request, published atomically under the run's directory, served from there afterwards."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import zipfile
from pathlib import Path

from fastapi import Request

from turbgen.service.state import ServiceState, require_token


def cached_product(state: ServiceState, request: Request, rid: str, final: Path, ready, build) -> Path:
    """``final`` once ``ready(final)``, built by ``build(final)`` first when it is not (one build per product at a
    time; a concurrent request for it waits and reuses it).

    Parameters
    ----------
    state : ServiceState
        The server's state.
    request : fastapi.Request
        The request (starting a computation needs the server's token).
    rid : str
        Run id.
    final : Path
        Where the product lies under the run's directory.
    ready : callable
        ``ready(final)`` True when the product is complete.
    build : callable
        ``build(final)`` computes and publishes it.

    Returns
    -------
    Path
        ``final``.
    """
    if ready(final):
        return final
    with state.lock_for(f"{rid}/{final.relative_to(state.catalog.run_dir(rid))}"):
        if not ready(final):
            require_token(request, state)
            build(final)
    return final


def build_export(store: Path, rid: str, fmt: str, request, final: Path) -> None:
    """Export ``store`` in format ``fmt`` into the directory ``final`` (several files as one .zip).

    Parameters
    ----------
    store : Path
        The run's complete store.
    rid : str
        Run id (names the files).
    fmt : str
        Export format.
    request : turbgen.export.ExportRequest
        Export options.
    final : Path
        The export's directory (absent).
    """
    from turbgen.export import export_store

    final.parent.mkdir(exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=final.parent, prefix=".tmp-"))
    try:
        name = f"{rid}.{fmt}" if fmt in ("bts", "hdf5") else rid
        result = export_store(store, fmt, tmp / name, request)
        files = sorted(Path(p) for p in result.paths)
        if len(files) > 1:
            with zipfile.ZipFile(tmp / f"{rid}-{fmt}.zip", "w") as z:
                for f in files:
                    z.write(f, f.name)
            for f in files:
                f.unlink()
        os.replace(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def build_validation(store: Path, final: Path) -> None:
    """The `turbgen validate` report of ``store`` (report.json) and its PNG plots (plots/) into ``final``.

    Parameters
    ----------
    store : Path
        The run's complete store.
    final : Path
        The validation's directory (replaced if incomplete).
    """
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


def build_lidar(store: Path, rid: str, lidar: str, final: Path) -> None:
    """`turbgen lidar --json` of ``store`` for the lidar preset ``lidar`` into the file ``final``.

    Parameters
    ----------
    store : Path
        The run's complete store.
    rid : str
        Run id (the report names its store /runs/<id>/store).
    lidar : str
        A lidar preset name.
    final : Path
        The report file (absent).
    """
    from turbgen.lidar.report import lidar_report
    from turbgen.store import open_store

    report = lidar_report(open_store(store), lidar).to_dict()
    report["store"] = f"/runs/{rid}/store"  # the server's paths stay private
    final.parent.mkdir(exist_ok=True)
    tmp = final.with_name(f".{final.name}.tmp-{os.getpid()}")
    tmp.write_text(json.dumps(report, default=float))
    os.replace(tmp, final)
