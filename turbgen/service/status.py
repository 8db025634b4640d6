"""The status of a run as the service shows it (GET /runs/<id>, the catalog listing)."""

from __future__ import annotations

import json
import re
from types import SimpleNamespace

from turbgen.service.catalog import Catalog
from turbgen.service.jobs import Jobs
from turbgen.store.layout import default_chunk_t, n_chunks


def run_status(catalog: Catalog, jobs: Jobs, rid: str) -> dict:
    """The JSON-able status of the recorded run ``rid``: id, model, parameters, grid, status (complete / running /
    queued / failed / interrupted), progress, and the summary, validation verdict or error where there is one."""
    req = catalog.request(rid)
    grid = req["run"]["grid"]
    out = {"id": rid, "model": req["model"], "parameters": {k: v for k, v in req["run"].items() if k != "grid"},
           "grid": grid, "preset": req.get("preset"), "turbgen": req.get("turbgen")}  # fmt: skip
    if "fit" in out["parameters"]:
        out["parameters"]["fit"] = True  # a replay (as requested): the fitted keys join once it is complete
    total = 3 * n_chunks(SimpleNamespace(nt=grid["nt"], nx=len(grid["x_m"])), default_chunk_t(grid["nt"]))
    summary = catalog.run_dir(rid) / "summary.json"  # written when the worker's result is back, after the store
    if catalog.is_complete(rid) and jobs.is_active(rid) and not summary.is_file():
        out["status"] = "running"  # the store is published, its summary (a replay's fitted values) not yet
        out["progress"] = {"chunks_done": total, "chunks_total": total}
    elif catalog.is_complete(rid):
        out["status"] = "complete"
        out["progress"] = {"chunks_done": total, "chunks_total": total}
        try:
            out["summary"] = json.loads(summary.read_text())
            out["parameters"] |= out["summary"].get("fit", {})  # a replay's fitted keys
            if "conditioning" in out["summary"]:  # what the command prints of the fit and the conditioning
                out["summary"]["conditioning"] = [public_text(t, catalog) for t in out["summary"]["conditioning"]]
        except (OSError, ValueError):
            pass
        rep = catalog.run_dir(rid) / "validation" / "report.json"
        if rep.is_file():
            out["validation"] = {"passed": json.loads(rep.read_text()).get("passed")}
    elif jobs.is_active(rid):
        done = catalog.progress(rid, total)
        out["status"] = "running" if done or catalog.temporaries(rid) else "queued"
        out["progress"] = {"chunks_done": done, "chunks_total": total}
    else:
        reason = catalog.failure(rid)
        out["status"] = "failed" if reason else "interrupted"
        out["error"] = None if reason is None else public_text(reason, catalog)
    return out


# advice in the library's messages about options of the CLI and the API that a client of the service cannot give
# (the service chooses every output path and never overwrites): dropped or replaced
_CLI_ADVICE = (
    ("; use `overwrite` to replace it", ""),
    (" (use `overwrite`)", ""),
    ("choose another `out` or lower", "or lower"),
    ("; it will not be replaced (choose another `out`)", "; it will not be replaced"),
    ("`out`", "the server's catalog"),
    ("pass `drop_below_ground`", "pass ?drop_below_ground=true"),
    ("raise `hub_height` above", "submit a run with hub_height_m above"),
    ("--fit (fit=True)", '"fit": true'),
)


def public_text(text: str, catalog: Catalog) -> str:
    """A library message as clients see it: server paths and upload names made ``/runs/<id>[/store]``,
    ``/constraints/<id>`` or ``<server root>/...``, the advice of :data:`_CLI_ADVICE` rewritten."""
    for root in dict.fromkeys((catalog.root, catalog.root.resolve())):
        runs = re.escape(str(root / "runs"))
        text = re.sub(runs + r"/([0-9a-f]{24})/store\.zarr\b", r"/runs/\1/store", text)
        text = re.sub(runs + r"/([0-9a-f]{24})\b", r"/runs/\1", text)
        text = re.sub(re.escape(str(root / "constraints")) + r"/([0-9a-f]{24})\.(json|csv)\b", r"/constraints/\1", text)
        text = text.replace(str(root), "<server root>")
    text = re.sub(r"(?<![\w/.-])([0-9a-f]{24})\.(json|csv)\b", r"/constraints/\1", text)  # an upload by its name
    for advice, instead in _CLI_ADVICE:
        text = text.replace(advice, instead)
    return text
