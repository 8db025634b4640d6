"""Design-load-case sets: a DLC preset (turbgen.spec.dlc) run as one sweep, every field exported with its runner
input files and listed in DIR/dlc_manifest.csv (columns: DLC_COLUMNS; TI = sigma1 / V_hub)."""

from __future__ import annotations

import csv
import io
from dataclasses import replace
from pathlib import Path

from turbgen.atomic import write_file
from turbgen.errors import ParameterError, check_choice
from turbgen.exporters import ExportRequest, export_store
from turbgen.exporters.inflowwind_file import inflowwind_path
from turbgen.runs.models import get_model
from turbgen.spec.dlc import DlcSet, dlc_models
from turbgen.store.paths import check_output_path
from turbgen.sweep.plan import PlannedRun, SweepPlan, check_grid_keys, check_plan_memory, grid_mapping
from turbgen.sweep.scheduler import check_scheduler_address

DLC_MANIFEST = "dlc_manifest.csv"
DLC_COLUMNS = ("file", "inflowwind_file", "dlc", "class", "V_hub_m_s", "TI", "sigma1_m_s", "seed", "model", "store")
WIND_DIR = "wind"
EXPORT_FORMATS = ("bts", "wnd", "hawc2")


def make_dlc_plan(dlc: DlcSet, *, out, model: str = "kaimal", grid=None, chunk_t: int | None = None,
                  workers: int | None = None, scheduler: str | None = None) -> SweepPlan:
    """The sweep of a DLC set: one run per speed and seed, named ``{model}_dlc1.2-IIB_U12_seed3``; ``model``
    "kaimal" (the standard's Annex C model) or "mann", the rest and the errors as :func:`make_plan`'s."""
    check_choice("model", model, dlc_models())
    grid = check_grid_keys("grid", grid)
    if scheduler:
        check_scheduler_address(scheduler)
    check_output_path(out, "out (sweep directory)", create_parents=True)
    spec = get_model(model).spec
    runs = []
    for U in dlc.speeds_m_s():
        first = spec.from_mapping({**dlc.run_mapping(model, U, dlc.seeds[0]), **grid_mapping(grid)})
        for s in dlc.seeds:
            runs.append(PlannedRun(model, dlc.label, U, s, first if s == dlc.seeds[0] else replace(first, seed=s)))
    if not scheduler:
        check_plan_memory(runs)
    return SweepPlan(Path(out), (model,), (dlc.label,), dlc.speeds_m_s(), dlc.seeds, grid, {}, False, chunk_t,
                     workers, scheduler or None, {}, tuple(runs))


def export_dlc(plan: SweepPlan, dlc: DlcSet, result, fmt: str = "bts") -> Path:
    """Export every complete field to DIR/wind/ in ``fmt`` ("bts", "wnd", "hawc2") with its runner files and write
    DIR/dlc_manifest.csv; return its path. Existing exports are kept (resumable); failed fields are left out."""
    check_choice("format", fmt, EXPORT_FORMATS)
    out = Path(plan.out)
    wind = out / WIND_DIR
    wind.mkdir(exist_ok=True)
    complete = {r["name"] for r in result.records if r["status"] == "complete"}
    rows = []
    for pr in plan.runs:
        if pr.name not in complete:
            continue
        target = wind / (f"{pr.name}.bts" if fmt == "bts" else pr.name)
        files = _export_one(out / pr.store_name, fmt, target)
        s1 = dlc.sigma1_m_s(pr.U_m_s)
        rows.append({"file": files[0].relative_to(out).as_posix(), "inflowwind_file": files[1].relative_to(out).as_posix(),
                     "dlc": dlc.dlc, "class": dlc.iec_class, "V_hub_m_s": f"{pr.U_m_s:g}", "TI": f"{s1 / pr.U_m_s:.6g}",
                     "sigma1_m_s": f"{s1:.6g}", "seed": pr.seed, "model": pr.model, "store": pr.store_name})
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=DLC_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_file(out / DLC_MANIFEST, buf.getvalue())
    return out / DLC_MANIFEST


def _export_one(store: Path, fmt: str, target: Path) -> tuple[Path, Path]:
    """(wind file, InflowWind input file) of one field, exported unless both exist already."""
    stem = target.with_suffix("") if fmt == "bts" else target
    first = {"bts": target, "wnd": Path(f"{target}.wnd"), "hawc2": Path(f"{target}_u.bin")}[fmt]
    dat = inflowwind_path(stem, fmt)
    if not (first.is_file() and dat.is_file()):
        try:
            export_store(store, fmt, target, ExportRequest(runner_files=True, overwrite=True))
        except ParameterError as err:
            raise ParameterError(f"exporting {store.name}: {err}") from None
    return first, dat
