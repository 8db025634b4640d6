"""Batch sweeps: models x stability presets x wind speeds x seeds on dask.distributed.

    from turbgen.sweep import make_plan, plan_from_file, run_sweep, summary_table
    plan = make_plan(out="study", models=["mann"], presets=["neutral", "stable"], speeds=[12, 16], seeds=range(1, 22))
    result = run_sweep(plan)          # resumable; DIR/manifest.json and manifest.csv
"""

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
