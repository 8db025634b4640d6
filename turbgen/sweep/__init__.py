"""Batch sweeps: models x stability presets x wind speeds x seeds on dask.distributed (make_plan or plan_from_file,
then run_sweep: resumable; DIR/manifest.json and manifest.csv)."""

from turbgen.sweep.lock import SweepLock, SweepLockedError
from turbgen.sweep.plan import PlannedRun, SweepPlan, make_plan, store_name
from turbgen.sweep.plan_file import plan_from_file, plan_from_mapping
from turbgen.sweep.runner import SweepResult, run_sweep, summary_table

__all__ = [
    "PlannedRun",
    "SweepLock",
    "SweepLockedError",
    "SweepPlan",
    "SweepResult",
    "make_plan",
    "plan_from_file",
    "plan_from_mapping",
    "run_sweep",
    "store_name",
    "summary_table",
]
