"""`turbgen sweep` end to end on a 2-worker LocalCluster: stores bit-identical to single runs, resume,
manifest, failure isolation, the directory lock."""

import json
import logging
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.store import open_store
from turbgen.sweep import SweepLock, make_plan, run_sweep
from turbgen.sweep.lock import LOCK_NAME
from turbgen.sweep.manifest import read_manifest, store_checksum

GRID = {"nt": 32, "dt": 0.5, "planes": [0.0, 40.0], "ny": 4, "nz": 4, "dy": 8.0}
CLI_GRID = ["--nt", "32", "--dt", "0.5", "--planes", "0,40", "--ny", "4", "--nz", "4", "--dy", "8"]
PRESETS, SPEEDS, SEEDS = ["neutral", "stable"], [12.0, 16.0], [1, 2, 3]


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as c:  # fmt: skip
        yield c


def _plan(out, model, **kw):
    return make_plan(out=out, models=[model], presets=PRESETS, speeds=SPEEDS, seeds=SEEDS, grid=GRID, **kw)


@pytest.fixture(scope="module", params=["kaimal", "mann"])
def swept(request, client, tmp_path_factory):
    """One full sweep per model (2 presets x 2 speeds x 3 seeds), shared by the tests below."""
    out = tmp_path_factory.mktemp(f"sweep_{request.param}")
    plan = _plan(out, request.param)
    result = run_sweep(plan, client=client, progress=False)
    return request.param, plan, result


def _same_field(a, b):
    fa, fb = open_store(a), open_store(b)
    assert fa.grid == fb.grid
    for c in "uvw":
        assert np.array_equal(fa.array(c)[:], fb.array(c)[:]), c  # bit for bit (float32, NaN-free)


def test_sweep_stores_equal_single_runs_bit_for_bit(swept, tmp_path):
    model, plan, result = swept
    assert result.ok and result.ran == 12 and result.skipped == 0
    runner = CliRunner()
    for pr in plan.runs:
        single = tmp_path / f"{pr.name}.zarr"
        args = [model, "--preset", pr.preset, "--U", f"{pr.U_m_s:g}", "--seed", str(pr.seed), *CLI_GRID,
                "--out", str(single)]  # fmt: skip
        res = runner.invoke(cli, args)
        assert res.exit_code == 0, res.output
        _same_field(plan.out / pr.store_name, single)
        rec = next(r for r in result.records if r["name"] == pr.name)
        assert rec["checksum"] == store_checksum(single)


def test_manifest_describes_every_run(swept):
    model, plan, result = swept
    doc = read_manifest(plan.out)
    assert doc["counts"] == {"complete": 12, "failed": 0, "pending": 0}
    assert [r["name"] for r in doc["runs"]] == [pr.name for pr in plan.runs]
    for pr, rec in zip(plan.runs, doc["runs"]):
        fs = open_store(plan.out / rec["path"])
        assert (rec["model"], rec["preset"], rec["U_m_s"], rec["seed"]) == (model, pr.preset, pr.U_m_s, pr.seed)
        assert rec["status"] == "complete" and rec["action"] == "ran" and rec["error"] is None
        assert rec["duration_s"] > 0 and rec["checksum"].startswith("sha256:")
        assert rec["parameters"] == fs.attrs["parameters"]
        # the recorded sigma_u is the generator's summary of the stored u over all points and planes
        # (run_mann: std about the mean; run_kaimal: rms)
        u = fs.array("u")[:].astype(np.float64)
        expected = np.std(u) if model == "mann" else np.sqrt(np.mean(u**2))
        assert rec["sigma_m_s"][0] == pytest.approx(expected, rel=1e-6)
    assert len(set(r["checksum"] for r in doc["runs"])) == 12  # seeds / speeds / presets give distinct fields
    csv_lines = (plan.out / "manifest.csv").read_text().splitlines()
    assert len(csv_lines) == 13 and csv_lines[0].startswith("name,model,preset,U_m_s,seed,status")


def test_interrupted_sweep_resumes_only_the_missing_runs(swept, client, tmp_path):
    model, plan, first = swept
    out = tmp_path / "resume"
    shutil.copytree(plan.out, out)
    names = [pr.name for pr in plan.runs]
    # what a kill leaves behind: missing stores, an incomplete store, a dead writer's temp dir, a stale lock
    for n in names[:2]:
        shutil.rmtree(out / f"{n}.zarr")
    meta = out / f"{names[5]}.zarr" / "zarr.json"
    doc = json.loads(meta.read_text())
    del doc["attributes"]["turbgen_complete"]
    meta.write_text(json.dumps(doc))
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    temp = out / f".{names[7]}.zarr.tmp-{dead.pid}-abcd"
    temp.mkdir()
    (out / LOCK_NAME).write_text(json.dumps({"host": socket.gethostname(), "pid": dead.pid}))
    kept = {n: (out / f"{n}.zarr" / "zarr.json").stat().st_mtime_ns for n in names if n not in (*names[:2], names[5])}

    result = run_sweep(make_plan(**{**_kwargs(plan), "out": out}), client=client, progress=False)
    assert result.ok and result.ran == 3 and result.skipped == 9
    ran = {r["name"] for r in result.records if r["action"] == "ran"}
    assert ran == {names[0], names[1], names[5]}
    for n, mtime in kept.items():
        assert (out / f"{n}.zarr" / "zarr.json").stat().st_mtime_ns == mtime  # untouched
    assert [r["checksum"] for r in result.records] == [r["checksum"] for r in first.records]
    assert not temp.exists() and not (out / LOCK_NAME).exists()  # the dead sweep's lock taken over, released
    # a third run does nothing
    again = run_sweep(make_plan(**{**_kwargs(plan), "out": out}), client=client, progress=False)
    assert again.ok and again.ran == 0 and again.skipped == 12


def _kwargs(plan):
    return dict(models=plan.models, presets=plan.presets, speeds=plan.speeds_m_s, seeds=plan.seeds, grid=plan.grid)


def test_existing_stores_with_other_parameters_are_never_overwritten(swept, client, tmp_path):
    model, plan, _ = swept
    out = tmp_path / "other"
    shutil.copytree(plan.out, out)
    before = store_checksum(out / plan.runs[0].store_name)
    manifest_before = (out / "manifest.json").read_text()
    other = make_plan(**{**_kwargs(plan), "out": out, "grid": {**GRID, "dy": 9.0}})
    # refused before anything is written: the records of the existing stores are not rewritten
    with pytest.raises(ParameterError, match="different grid.*nothing run, manifest unchanged"):
        run_sweep(other, client=client, progress=False)
    assert store_checksum(out / plan.runs[0].store_name) == before
    assert (out / "manifest.json").read_text() == manifest_before
    # the command: its one error line is all it prints (no "sweep: N runs" line before it)
    res = CliRunner().invoke(cli, ["sweep", "--model", model, "--preset", ",".join(PRESETS), "--speeds",
                                   ",".join(f"{v:g}" for v in SPEEDS), "--seeds", ",".join(map(str, SEEDS)),
                                   *CLI_GRID[:-1], "9", "--out", str(out)])
    assert res.exit_code == 2 and res.stdout == "", res.output
    assert res.stderr.strip().splitlines() == [res.stderr.strip()] and "different grid" in res.stderr
    assert (out / "manifest.json").read_text() == manifest_before


def test_one_failing_run_does_not_stop_the_others_and_sets_the_exit_code(client, tmp_path):
    out = tmp_path / "fail"
    out.mkdir()
    (out / "kaimal_stable_U16_seed2.zarr").write_text("not a store")  # e.g. a stray file where a store goes
    cfg = tmp_path / "s.json"
    cfg.write_text(json.dumps({"out": str(out), "models": ["kaimal"], "presets": PRESETS, "speeds": SPEEDS,
                               "seeds": "1-3", "grid": GRID}))  # fmt: skip
    res = CliRunner().invoke(cli, ["sweep", "--config", str(cfg), "--scheduler", client.scheduler.address])
    assert res.exit_code == 1, res.output
    doc = read_manifest(out)
    bad = [r for r in doc["runs"] if r["status"] != "complete"]
    assert [r["name"] for r in bad] == ["kaimal_stable_U16_seed2"] and "StoreError" in bad[0]["error"]
    assert doc["counts"]["complete"] == 11
    assert "kaimal_stable_U16_seed2" in res.output and "11/12 complete" in res.output


def test_lock_refuses_a_second_concurrent_sweep(tmp_path):
    out = tmp_path / "locked"
    out.mkdir()
    with SweepLock(out):  # a live sweep (this process) holds the directory
        res = CliRunner().invoke(cli, ["sweep", "--model", "kaimal", "--preset", "neutral", "--speeds", "16",
                                       "--seeds", "1", *CLI_GRID, "--out", str(out)])  # fmt: skip
    assert res.exit_code == 2
    assert "locked by another sweep" in res.output and res.output.count("\n") == 1  # the error line only
    assert sorted(p.name for p in out.iterdir()) == []  # nothing written (our lock file removed on release)


def test_mann_stencil_is_built_once_per_parameter_set(client, tmp_path):
    from distributed import get_task_stream

    plan = make_plan(out=tmp_path / "st", models=["mann"], presets=["neutral"], speeds=[12.0, 16.0], seeds=[1, 2, 3],
                     grid=GRID)  # fmt: skip
    with get_task_stream(client) as ts:
        result = run_sweep(plan, client=client, progress=False)
    assert result.ok and result.ran == 6
    names = [t["key"] if isinstance(t["key"], str) else t["key"][0] for t in ts.data]
    assert sum(n.startswith("turbgen-shared-mann") for n in names) == 2  # one per speed, shared by 3 seeds
    assert sum(n.startswith("turbgen-run-") for n in names) == 6


def test_validate_adds_a_summary_without_regenerating(client, tmp_path):
    out = tmp_path / "val"
    args = ["sweep", "--model", "kaimal", "--preset", "neutral", "--speeds", "16", "--seeds", "1-2", "--nt", "512",
            "--ny", "8", "--nz", "8", "--dy", "20", "--planes", "0,50", "--out", str(out),
            "--scheduler", client.scheduler.address]  # fmt: skip
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert all(r["validation"] is None for r in read_manifest(out)["runs"])
    res = CliRunner().invoke(cli, [*args, "--validate"])  # the stores exist: only validated now
    doc = read_manifest(out)
    assert [r["action"] for r in doc["runs"]] == ["skipped", "skipped"]
    for r in doc["runs"]:
        v = r["validation"]
        assert set(v) == {"passed", "failed", "max_abs_z", "seconds"} and "sigma_u" in v["max_abs_z"]
        assert v["passed"] == (not v["failed"])
    all_passed = all(r["validation"]["passed"] for r in doc["runs"])
    assert res.exit_code == (0 if all_passed else 3), res.output


@pytest.mark.slow
def _in_group(proc_dir, pgid: int) -> bool:
    """True if /proc/PID belongs to process group pgid and is not a zombie."""
    try:
        fields = (proc_dir / "stat").read_text().rsplit(")", 1)[-1].split()
    except OSError:
        return False
    return fields[0] != "Z" and int(fields[2]) == pgid


def test_killed_sweep_process_is_resumed(client, tmp_path):
    """SIGKILL a real `turbgen sweep` (process group: client, scheduler, workers) after its first field."""
    import os
    import signal
    import time

    out = tmp_path / "killed"
    args = ["sweep", "--model", "kaimal", "--preset", "stable", "--speeds", "16", "--seeds", "1-8", "--nt", "4096",
            "--ny", "12", "--nz", "12", "--dy", "10", "--planes", "0,50,100", "--out", str(out)]  # fmt: skip
    cmd = [sys.executable, "-c", "from turbgen.cli import main; main()", *args, "--workers", "1"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            doc = read_manifest(out) if out.exists() else None
            if doc and doc["counts"]["complete"] >= 1:
                break
            time.sleep(0.02)
        os.killpg(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    # SIGKILL is delivered asynchronously: wait until every process of the group is gone (the user's
    # rerun comes after the kill), reading zombies as gone like the lock does
    group_deadline = time.monotonic() + 30
    while time.monotonic() < group_deadline:
        members = [int(p.name) for p in Path("/proc").iterdir() if p.name.isdigit() and _in_group(p, proc.pid)]
        if not members:
            break
        time.sleep(0.05)
    before = read_manifest(out)
    done = [r["name"] for r in before["runs"] if r["status"] == "complete"]
    assert 1 <= len(done) < 8, "the sweep was not interrupted midway"
    assert (out / LOCK_NAME).read_text()  # left naming the killed sweep, which holds no OS lock: taken over below
    res = CliRunner().invoke(cli, [*args, "--scheduler", client.scheduler.address])
    assert res.exit_code == 0, res.output
    after = read_manifest(out)
    assert after["counts"]["complete"] == 8
    assert {r["name"] for r in after["runs"] if r["action"] == "skipped"} >= set(done)
    assert sum(r["action"] == "ran" for r in after["runs"]) == 8 - len(
        [r for r in after["runs"] if r["action"] == "skipped"]
    )
    assert not [p for p in out.iterdir() if ".tmp-" in p.name] and not (out / LOCK_NAME).exists()


def test_a_second_sweep_into_the_same_directory_adds_to_the_manifest(client, tmp_path):
    kw = dict(out=tmp_path / "two", models=["kaimal"], presets=["neutral"], speeds=[16.0], grid=GRID)
    first = run_sweep(make_plan(seeds=[1, 2], **kw), client=client, progress=False)
    second = run_sweep(make_plan(seeds=[2, 3], **kw), client=client, progress=False)
    assert (second.ran, second.skipped) == (1, 1)
    doc = read_manifest(tmp_path / "two")
    by_name = {r["name"]: r for r in doc["runs"]}
    assert sorted(by_name) == [f"kaimal_neutral_U16_seed{s}" for s in (1, 2, 3)]
    assert by_name["kaimal_neutral_U16_seed1"] == first.records[0]  # kept as the first sweep wrote it
    assert doc["counts"]["complete"] == 3
