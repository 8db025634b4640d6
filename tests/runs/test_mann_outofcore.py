"""Out-of-core Mann runs (turbgen.runs.mann_outofcore, `turbgen mann --memory`): same field bit for bit as
in memory, memory bound, kill -9 during either pass, disk check, sizes."""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.errors import ParameterError, StoreError
from turbgen.resources import parse_size
from turbgen.runs import mann_outofcore as ooc
from turbgen.runs.mann import memory_estimate_bytes, run_mann
from turbgen.spec.mann import MannRun
from turbgen.store import open_store

SMALL = {"nt": 64, "ny": 9, "nz": 10, "x_m": [0.0, 50.0, 100.0]}  # 90 (y, z) points: a short last row block
# a field whose in-memory estimate (~500 MiB) exceeds the budgets below; ~6 s out of core on 2 cores
MID_ARGS = ["mann", "--nt", "2048", "--ny", "48", "--nz", "48", "--planes", "0,50,100", "--ae", "0.3"]


@pytest.fixture(autouse=True)
def _plans_independent_of_this_process(monkeypatch):
    """Plans made in this (long-lived pytest) process take the fixed BASE_BYTES, not what pytest holds resident by
    then; the budget tests run the CLI in a fresh process (_vmhwm_run), where the resident memory counts."""
    monkeypatch.setattr(ooc, "resident_bytes", lambda: None)
    monkeypatch.setattr(ooc, "_IMPORTED_RESIDENT", None)


def _same(a, b) -> bool:
    fa, fb = open_store(a), open_store(b)
    return all(np.array_equal(fa.array(c)[...], fb.array(c)[...]) for c in "uvw")


@pytest.mark.parametrize(
    "grid, extra",
    [(SMALL, {}), (SMALL, {"evo_time_s": None}), ({**SMALL, "x_m": [0.0]}, {}), ({**SMALL, "nt": 66}, {"seed": 4})],
)
def test_same_field_as_in_memory_for_any_parts_blocks_and_threads(tmp_path, grid, extra):
    run = MannRun.from_mapping({"grid": grid, **extra})
    run_mann(run, tmp_path / "ref.zarr", threads=2)
    sizes = [  # (slabs per part, points per block, plane in memory, threads)
        (4, 64, False, 1),
        (12, 64, True, 2),
        (36, 128, False, 2),
    ]
    for n, (slabs, block, in_memory, threads) in enumerate(sizes):
        plan = ooc.OutOfCorePlan(run, 2**30, threads, chunk_t=16 + 8 * n, slabs_per_part=slabs, block_points=block,
                                 plane_in_memory=in_memory)  # fmt: skip
        out = tmp_path / f"o{n}.zarr"
        ooc.run_mann_outofcore(run, out, memory_bytes=2**30, threads=threads, plan=plan)
        assert _same(tmp_path / "ref.zarr", out), (slabs, block, in_memory, threads)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o0.zarr", "o1.zarr", "o2.zarr", "ref.zarr"]  # no scratch


def test_plan_follows_the_budget_and_refuses_a_too_small_one():
    run = MannRun.from_mapping({"grid": {"nt": 2048, "ny": 48, "nz": 48, "x_m": [0.0, 50.0]}, "ae": 0.3})
    small, large = ooc.OutOfCorePlan(run, 300 * 2**20, 2), ooc.OutOfCorePlan(run, 2**30, 2)  # above the 250 MiB base
    assert small.n_parts > large.n_parts >= 1 and small.slabs_per_part % 4 == 0
    assert not small.plane_in_memory and large.plane_in_memory
    with pytest.raises(ParameterError, match="raise `memory`") as given:
        ooc.OutOfCorePlan(run, 100 * 2**20, 2)
    assert "`ae`" not in str(given.value)  # ae was given: nothing to suggest
    computed = MannRun.from_mapping({"grid": {"nt": 2048, "ny": 48, "nz": 48, "x_m": [0.0, 50.0]}})
    with pytest.raises(ParameterError, match=r"or give `ae` \(here \d"):  # its sigma_u quadrature left memory resident
        ooc.OutOfCorePlan(computed, 100 * 2**20, 2)


def test_cli_memory_option_goes_out_of_core_with_the_same_field(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    args = ["mann", "--nt", "64", "--ny", "9", "--nz", "10", "--planes", "0,50"]
    assert CliRunner().invoke(cli, [*args, "--out", "a.zarr"]).exit_code == 0
    monkeypatch.setattr(ooc, "base_bytes", lambda: 0)  # the interpreter's own share aside
    res = CliRunner().invoke(cli, [*args, "--memory", "48MiB", "--out", "b.zarr"])
    assert res.exit_code == 0, res.output
    assert "out-of-core: budget 48.0 MiB" in res.output
    assert _same(tmp_path / "a.zarr", tmp_path / "b.zarr")
    res = CliRunner().invoke(cli, [*args, "--memory", "2MiB", "--out", "c.zarr"])
    assert res.exit_code == 2 and "raise --memory" in res.output and len(res.output.strip().splitlines()) == 1
    res = CliRunner().invoke(cli, [*args, "--memory", "lots", "--out", "c.zarr"])
    assert res.exit_code == 2 and "--memory 'lots'" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.zarr", "b.zarr"]


def test_disk_space_is_checked_before_anything_is_written(tmp_path, monkeypatch):
    run = MannRun.from_mapping({"grid": SMALL})
    monkeypatch.setattr("turbgen.resources.available_disk_bytes", lambda path: 1000)
    with pytest.raises(ParameterError, match="disk space.*free disk space or write `out` elsewhere"):
        ooc.run_mann_outofcore(run, tmp_path / "a.zarr", memory_bytes=2**30, threads=1)
    assert list(tmp_path.iterdir()) == []


def _vmhwm_run(args, cwd, kill_when=None):
    """Run the CLI in a subprocess printing its VmHWM [KiB]; kill -9 it once kill_when(cwd) is true."""
    code = (
        "import sys\nfrom turbgen.cli import main\nsys.argv[0] = 'turbgen'\ntry:\n    main()\nfinally:\n"
        "    print('VmHWM', open('/proc/self/status').read().split('VmHWM:')[1].split()[0], file=sys.stderr)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code, *args], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    if kill_when is None:
        out, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
        return int(err.split("VmHWM")[1].split()[0])
    deadline = time.monotonic() + 120
    while not kill_when(cwd) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert proc.poll() is None, "the run ended before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.communicate()
    return None


def _budget_mib(args, floor_mib: int) -> int:
    """A budget [MiB] the command ``args`` can run in: ``floor_mib``, or 16 MiB over the least its plan accepts in a
    fresh process if that is more (what the interpreter holds resident varies with the environment: a freshly
    installed llvmlite maps ~45 MiB more; the plan counts it, so the budget must too)."""
    code = "import sys\nfrom turbgen.cli import main\nsys.argv[0] = 'turbgen'\nmain()\n"
    res = subprocess.run([sys.executable, "-c", code, *args, "--memory", "1MiB", "--out", "never.zarr"],
                         capture_output=True, text=True, timeout=300)  # fmt: skip
    need = re.search(r"needs at least ([0-9.]+) (MiB|GiB)", res.stdout + res.stderr)
    assert res.returncode == 2 and need, res.stdout + res.stderr
    # the message rounds to 0.1 of its unit: add the half unit it may have rounded away
    need_mib = float(need.group(1)) * 1024 + 52 if need.group(2) == "GiB" else float(need.group(1)) + 0.05
    return max(floor_mib, math.ceil(need_mib) + 16)


def test_peak_memory_stays_within_the_budget(tmp_path):
    run = MannRun.from_mapping({"grid": {"nt": 2048, "ny": 48, "nz": 48, "x_m": [0.0, 50.0, 100.0]}, "ae": 0.3})
    budget_mib = _budget_mib(MID_ARGS, 320)
    assert memory_estimate_bytes(run, 2) > budget_mib * 2**20  # in memory it would not fit
    hwm_kib = _vmhwm_run([*MID_ARGS, "--memory", f"{budget_mib}MiB", "--out", "a.zarr"], tmp_path)
    assert hwm_kib * 1024 <= budget_mib * 2**20, (hwm_kib / 1024, budget_mib)
    assert open_store(tmp_path / "a.zarr").attrs["turbgen_complete"] is True


def test_peak_memory_stays_within_the_budget_when_ae_is_computed(tmp_path):
    # ae from the default sigma_u: its quadrature leaves ~70-125 MiB more resident than a given ae, which the plan
    # once ignored (a fixed 250 MiB for the interpreter: 438 MiB peak in this 380 MiB budget, 344 MiB in 340 MiB)
    args = ["mann", "--nt", "2048", "--ny", "32", "--nz", "32"]
    budget_mib = _budget_mib(args, 420)
    hwm_kib = _vmhwm_run([*args, "--memory", f"{budget_mib}MiB", "--out", "a.zarr"], tmp_path)
    assert hwm_kib * 1024 <= budget_mib * 2**20, (hwm_kib / 1024, budget_mib)
    assert open_store(tmp_path / "a.zarr").attrs["turbgen_complete"] is True


def test_base_follows_what_is_resident(monkeypatch):
    monkeypatch.setattr(ooc, "resident_bytes", lambda: 400 * 2**20)
    assert ooc.base_bytes() == 400 * 2**20 + ooc.LATE_BYTES
    monkeypatch.setattr(ooc, "resident_bytes", lambda: 100 * 2**20)
    assert ooc.base_bytes() == ooc.BASE_BYTES
    monkeypatch.setattr(ooc, "resident_bytes", lambda: None)  # no /proc
    assert ooc.base_bytes() == ooc.BASE_BYTES


def test_scheduler_of_a_field_that_fits_is_reported_unused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(cli, ["mann", "--nt", "64", "--ny", "9", "--nz", "10", "--scheduler", "tcp://127.0.0.1:1",
                                   "--out", "a.zarr"])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "--scheduler tcp://127.0.0.1:1 not used: the field fits" in res.output


def test_local_cluster_plan_shares_the_budget_with_this_process():
    run = MannRun.from_mapping({"grid": {"nt": 8192, "ny": 48, "nz": 48, "x_m": [0.0, 50.0]}, "ae": 0.3})
    here = ooc.BASE_BYTES + ooc.LOCAL_CLUSTER_BYTES  # this process (the fixture: BASE_BYTES) and the cluster's share
    worker = ooc.OutOfCorePlan(run, 2**62, 1, base=ooc.BASE_BYTES).minimum_bytes
    assert memory_estimate_bytes(run, 2) + ooc.BASE_BYTES > here + 2 * worker + 2**20  # not in memory
    with pytest.raises(ParameterError, match="local cluster of 2 workers needs at least .* each worker"):
        ooc.plan_for_budget(run, here + 2 * worker - 1, 2, scheduler="local")
    plan = ooc.plan_for_budget(run, here + 2 * worker + 2**20, 2, scheduler="local")
    assert plan.memory_bytes == (2 * worker + 2**20) // 2 and plan.threads == 1 and "per worker" in plan.describe()
    assert ooc.plan_for_budget(run, 2**40, 2, scheduler="local") is None  # fits in memory: no cluster
    assert not ooc.plan_for_budget(run, 400 * 2**20, 2).per_worker


def test_local_cluster_run_stays_within_the_shared_budget(tmp_path):
    # this process's peak plus each worker's (the largest child's) bounds what the processes held at once
    code = (
        "import resource, sys\nfrom turbgen.cli import main\nsys.argv[0] = 'turbgen'\ntry:\n    main()\nfinally:\n"
        "    hwm = int(open('/proc/self/status').read().split('VmHWM:')[1].split()[0])\n"
        "    print('KIB', hwm, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
    )
    args = ["mann", "--nt", "6144", "--ny", "48", "--nz", "48", "--planes", "0,50,100", "--threads", "2",
            "--scheduler", "local"]  # fmt: skip
    budget_mib = _budget_mib(args, 1280)
    args += ["--memory", f"{budget_mib}MiB", "--out", "a.zarr"]
    res = subprocess.run([sys.executable, "-c", code, *args], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert "per worker" in res.stdout
    parent_kib, worker_kib = (int(v) for v in res.stdout.split("KIB")[1].split())
    tracker_kib = 16 * 1024  # multiprocessing's resource tracker, alive until this process exits (15 MiB measured)
    assert (parent_kib + 2 * worker_kib + tracker_kib) * 1024 <= budget_mib * 2**20, (parent_kib, worker_kib)
    assert open_store(tmp_path / "a.zarr").attrs["turbgen_complete"] is True


def _scratch_dirs(d):
    return [p for p in d.iterdir() if ".scratch-" in p.name]


def _pass2_started(d):  # the store's temporary directory holds chunks of u: pass 2 is writing
    return any((p / "u" / "c").exists() and any((p / "u" / "c").rglob("*")) for p in d.iterdir() if ".tmp-" in p.name)


@pytest.mark.parametrize("when", ["pass 1", "pass 2"])
def test_kill_9_leaves_no_store_and_the_rerun_no_scratch(tmp_path, monkeypatch, when):
    args = [*MID_ARGS, "--memory", f"{_budget_mib(MID_ARGS, 320)}MiB", "--out", "k.zarr"]
    started = (lambda d: bool(_scratch_dirs(d))) if when == "pass 1" else _pass2_started
    _vmhwm_run(args, tmp_path, kill_when=started)
    assert not (tmp_path / "k.zarr").exists()
    assert _scratch_dirs(tmp_path)  # left behind by the killed process ...
    for p in tmp_path.iterdir():  # ... and nothing that looks like a complete store
        assert not (p / "zarr.json").exists() or "turbgen_complete" not in (p / "zarr.json").read_text()
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(cli, ["mann", "--nt", "64", *args[3:]])  # the rerun (shorter, the same output)
    assert res.exit_code == 0, res.output
    assert "scratch of a run that was killed" in res.output
    assert _scratch_dirs(tmp_path) == [] and open_store(tmp_path / "k.zarr").attrs["turbgen_complete"] is True


def test_parse_size():
    assert parse_size("256MiB") == 256 * 2**20 and parse_size("4GiB") == 4 * 2**30
    assert parse_size("1.5GB") == 1_500_000_000 and parse_size("1000") == 1000
    for bad in ("", "-1GiB", "0", "12XB", "GiB"):
        with pytest.raises(ParameterError, match="size"):
            parse_size(bad, "--memory")


def test_sweep_memory_budget_makes_the_same_fields_out_of_core(tmp_path, monkeypatch):
    from turbgen.sweep import make_plan, run_sweep

    monkeypatch.setattr(ooc, "base_bytes", lambda: 0)  # threads-only cluster: the workers share this monkeypatch
    calls = []
    real = ooc.run_mann_outofcore
    monkeypatch.setattr(ooc, "run_mann_outofcore", lambda *a, **k: calls.append(a[1]) or real(*a, **k))
    grid = {"nt": 64, "dt": 0.5, "planes": [0.0, 40.0], "ny": 9, "nz": 10, "dy": 8.0}
    plan = make_plan(out=tmp_path / "sw", models=["mann"], presets=["neutral"], speeds=[12.0], seeds=[1, 2], grid=grid,
                     workers=1)  # fmt: skip
    result = run_sweep(plan, processes=False, progress=False, memory_bytes=48 * 2**20)
    assert result.ok and len(calls) == 2
    for pr in plan.runs:
        run_mann(pr.run, tmp_path / f"ref{pr.run.seed}.zarr", threads=1)
        assert _same(tmp_path / f"ref{pr.run.seed}.zarr", plan.out / pr.store_name)


def test_both_passes_as_dask_tasks_give_the_same_field(tmp_path):
    import logging

    from distributed import Client, LocalCluster, get_task_stream

    run = MannRun.from_mapping({"grid": SMALL})
    run_mann(run, tmp_path / "ref.zarr", threads=2)
    plan = ooc.OutOfCorePlan(run, 2**30, 1, slabs_per_part=8, block_points=64)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:  # fmt: skip
        with get_task_stream(client) as stream:
            ooc.run_mann_outofcore(run, tmp_path / "d.zarr", memory_bytes=2**30, threads=1, plan=plan, client=client)
    # 5 parts of 8 slabs (33 slabs), then 3 snapshots x 3 components x 2 blocks of (y, z) points (90 points)
    assert len(stream.data) == 5 + 3 * 3 * 2
    assert len({t["worker"] for t in stream.data}) == 2  # spread over both workers
    assert _same(tmp_path / "ref.zarr", tmp_path / "d.zarr")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.zarr", "ref.zarr"]


@pytest.mark.parametrize("fail_at", [1, 5])  # the first write of pass 1, the 5th of pass 2 (to the plane file)
def test_disk_full_during_a_pass_leaves_no_store_and_no_scratch(tmp_path, monkeypatch, fail_at):
    import errno

    run = MannRun.from_mapping({"grid": SMALL})
    plan = ooc.OutOfCorePlan(run, 2**30, 1, slabs_per_part=8, block_points=64, plane_in_memory=False)
    n_pass1_writes = 5 * 3 * 3  # parts x snapshots x components
    real, count = ooc._File.write, [0]

    def write(self, offset, data):
        count[0] += 1
        if count[0] == (fail_at if fail_at == 1 else n_pass1_writes + fail_at):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, offset, data)

    monkeypatch.setattr(ooc._File, "write", write)
    # the store writer words ENOSPC as a StoreError (an OSError from the scratch file passes through)
    with pytest.raises((OSError, StoreError), match="No space"):
        ooc.run_mann_outofcore(run, tmp_path / "f.zarr", memory_bytes=2**30, threads=1, plan=plan)
    assert list(tmp_path.iterdir()) == []
