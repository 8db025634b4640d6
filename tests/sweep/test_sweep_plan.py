"""Sweep definitions (files, options, schema), store names, the directory lock and the manifest files."""

import csv
import json
import os
import subprocess
import sys

import click
import pytest

from turbgen.errors import ParameterError
from turbgen.spec.preset_runs import kaimal_settings_for
from turbgen.sweep import SweepLock, SweepLockedError, make_plan, plan_from_file, store_name
from turbgen.sweep.lock import LOCK_NAME
from turbgen.sweep.manifest import read_manifest, write_manifest
from turbgen.runs.models import MODELS

TINY = {"nt": 16, "dt": 0.5, "planes": [0.0, 50.0], "ny": 3, "nz": 3, "dy": 10.0}


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_plan_from_options_builds_every_combination(tmp_path):
    plan = make_plan(out=tmp_path, models=["kaimal"], presets=["neutral", "stable"], speeds=[12, 16.5], seeds=[1, 2, 3],
                     grid=TINY)  # fmt: skip
    assert len(plan.runs) == 2 * 2 * 3
    names = [r.store_name for r in plan.runs]
    assert names[0] == "kaimal_neutral_U12_seed1.zarr" and "kaimal_stable_U16.5_seed3.zarr" in names
    assert len(set(names)) == len(names)
    r = next(r for r in plan.runs if r.name == "kaimal_stable_U16.5_seed2")
    k = kaimal_settings_for("stable", 16.5)
    assert (r.run.seed, r.run.U_m_s, r.run.a_x, r.run.b_x) == (2, 16.5, k.a_x, k.b_x)
    assert r.run.kaimal == k.kaimal
    assert (r.run.grid.nt, r.run.grid.x_m, r.run.grid.dz_m) == (16, (0.0, 50.0), 10.0)  # dz defaults to dy
    assert store_name("mann", "neutral", 16.0, 2) == "mann_neutral_U16_seed2.zarr"


def test_plan_from_toml_and_json_files(tmp_path):
    (tmp_path / "mine.toml").write_text(
        '[presets.gusty.kaimal]\nsigma_ratios = [1, 0.8, 0.5]\nlength_scales_m = [300.0, 100.0, 30.0]\n'
        "a_yz = 10.0\nlc_m = 300.0\na_x = 2.0\nb_x = 1e-4\n"
    )
    (tmp_path / "s.toml").write_text(
        'out = "study"\nmodels = ["kaimal"]\npresets = ["neutral", "gusty"]\nspeeds = [12, 14]\nseeds = "1-2,5"\n'
        'preset_file = "mine.toml"\nchunks = 8\n[grid]\nnt = 16\ndt = 0.5\nplanes = [0, 50]\nny = 3\nnz = 3\n'
        "dy = 10.0\n[kaimal]\nnz = 5\n"
    )
    plan = plan_from_file(tmp_path / "s.toml")
    assert plan.out == tmp_path / "study" and plan.seeds == (1, 2, 5) and plan.chunk_t == 8
    assert len(plan.runs) == 2 * 2 * 3 and plan.runs[-1].run.grid.nz == 5  # model table overrides grid
    gusty = next(r for r in plan.runs if r.preset == "gusty")
    assert gusty.run.a_x == 2.0 and gusty.run.kaimal.a_yz == 10.0
    doc = {"models": ["kaimal"], "presets": ["neutral"], "speeds": [16], "seeds": [3], "grid": TINY, "validate": True}
    (tmp_path / "s.json").write_text(json.dumps(doc))
    plan = plan_from_file(tmp_path / "s.json", out=tmp_path / "o", workers=2)
    assert plan.validate and plan.workers == 2 and [r.name for r in plan.runs] == ["kaimal_neutral_U16_seed3"]


@pytest.mark.parametrize(
    "change, match",
    [
        ({"models": ["les"]}, "models/0"),
        ({"speeds": []}, "speeds"),
        ({"seeds": "1-x"}, "seeds"),
        ({"seeds": "5-3"}, "backwards"),
        ({"grid": {"nt": 16, "Nt": 3}}, "Nt"),
        ({"presets": ["windy"]}, "windy"),
        ({"bogus": 1}, "bogus"),
        ({"out": None}, "output directory"),
        ({"grid": {"ny": 0}}, "ny"),
        ({"workers": 2, "scheduler": "tcp://x:1"}, "exclude"),
        # a time chunk longer than a run's record failed every run at write time (found with --chunks 100000)
        ({"chunks": 17}, r"chunks .*= 17 .*\[1, 16\]"),
    ],
)
def test_bad_sweep_files_give_one_line_errors(tmp_path, change, match):
    doc = {"out": "o", "models": ["kaimal"], "presets": ["neutral"], "speeds": [16], "seeds": [1], "grid": TINY}
    doc.update(change)
    doc = {k: v for k, v in doc.items() if v is not None}
    (tmp_path / "s.json").write_text(json.dumps(doc))
    with pytest.raises(ParameterError, match=match) as info:
        plan_from_file(tmp_path / "s.json")
    assert "\n" not in str(info.value)


def test_a_lidar_that_does_not_fit_the_grid_is_refused_before_any_run(tmp_path):
    # found with `turbgen sweep ... --ny 8 --nz 8 --lidar nacelle-4beam`: every field was generated, then
    # each lidar run failed ("lidar coherence failed", exit 3) because the beams leave the 33 m wide field
    grid = {"nt": 256, "ny": 8, "nz": 8, "dy": 4.7}
    with pytest.raises(ParameterError, match="leaves the yz field") as info:
        make_plan(out=tmp_path / "o", models=["mann"], presets=["neutral"], speeds=[16], seeds=[1], grid=grid,
                  lidar="nacelle-4beam")  # fmt: skip
    assert "\n" not in str(info.value) and not (tmp_path / "o").exists()
    with pytest.raises(ParameterError, match="between the store's planes"):
        make_plan(out=tmp_path / "o", models=["mann"], presets=["neutral"], speeds=[16], seeds=[1],
                  grid={**grid, "ny": 16, "nz": 16, "dy": 8.0, "planes": [0, 50, 100]}, lidar="nacelle-4beam")
    ok = make_plan(out=tmp_path / "o", models=["mann"], presets=["neutral"], speeds=[16], seeds=[1],
                   grid={**grid, "ny": 16, "nz": 16, "dy": 8.0}, lidar="nacelle-4beam")  # fmt: skip
    assert len(ok.runs) == 1


def test_duplicate_names_and_missing_model_parameters(tmp_path):
    with pytest.raises(ParameterError, match="duplicate store names"):
        make_plan(out=tmp_path, models=["kaimal"], presets=["neutral"], speeds=[16, 16.0000001], seeds=[1], grid=TINY)
    with pytest.raises(ParameterError, match="duplicate"):
        make_plan(out=tmp_path, models=["kaimal"], presets=["neutral", "neutral"], speeds=[16], seeds=[1])


def test_command_defaults_match_the_single_run_commands():
    """The sweep's missing grid options must take exactly the defaults of `turbgen mann|kaimal`: the
    commands' options have no defaults of their own (the spec's from_mapping applies them), and a
    sweep run without grid options has the grid and hub height of the spec defaults."""
    import importlib

    from turbgen.spec.defaults import KAIMAL_DEFAULTS, KAIMAL_GRID, MANN_DEFAULTS, MANN_GRID
    from turbgen.sweep.plan import build_run

    option = {"nt": "nt", "dt": "dt_s", "ny": "ny", "nz": "nz", "dy": "dy_m", "hub_height": "hub_height_m"}
    for model, (defaults, grid) in {"mann": (MANN_DEFAULTS, MANN_GRID), "kaimal": (KAIMAL_DEFAULTS, KAIMAL_GRID)}.items():
        assert model in MODELS
        cmd = getattr(importlib.import_module(f"turbgen.cli.{model}"), model)
        ctx = click.Context(cmd)
        own = {p.name: p.get_default(ctx) for p in cmd.params if isinstance(p, click.Option)}
        assert all(own[name] in (None, getattr(click.core, "UNSET", None)) for name in option), (model, own)
        run = build_run(model, "neutral", 16.0, 1)
        g = run.grid
        assert (g.nt, g.dt_s, g.ny, g.nz, g.dy_m, g.dz_m, g.x_m) == (
            grid["nt"], grid["dt_s"], grid["ny"], grid["nz"], grid["dy_m"], grid["dy_m"], grid["x_m"])
        assert run.hub_height_m == defaults["hub_height_m"]


def test_lock_refuses_a_live_owner_and_takes_over_a_dead_one(tmp_path):
    with SweepLock(tmp_path):
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()  # names its owner
        with pytest.raises(SweepLockedError, match=f"pid {os.getpid()}"):
            SweepLock(tmp_path).acquire()
    assert not (tmp_path / LOCK_NAME).exists()  # released: removed while held
    # a lock file left by a killed sweep holds no OS lock any more (whatever it names): taken over
    (tmp_path / LOCK_NAME).write_text(json.dumps({"host": "elsewhere", "pid": _dead_pid()}))
    with SweepLock(tmp_path) as lock:
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid() == lock.owner["pid"]
    # a sweep in another process holds it: refused, naming that process
    code = ("import sys, time; from turbgen.sweep import SweepLock\n"
            f"with SweepLock({str(tmp_path)!r}):\n    print('held', flush=True); sys.stdin.read()")
    holder = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(SweepLockedError, match=f"pid {holder.pid} "):
            SweepLock(tmp_path).acquire()
    finally:
        holder.communicate("", timeout=60)
    with SweepLock(tmp_path):  # free again once that process let go
        pass


def test_manifest_json_and_csv_agree(tmp_path):
    recs = [
        {"name": "a", "model": "mann", "preset": "neutral", "U_m_s": 16.0, "seed": 1, "status": "complete",
         "action": "ran", "duration_s": 1.5, "path": "a.zarr", "checksum": "sha256:00", "sigma_m_s": [1.0, 0.8, 0.5],
         "validation": {"passed": True}, "error": None, "parameters": {"L": 49.0}},
        {"name": "b", "model": "mann", "preset": "neutral", "U_m_s": 16.0, "seed": 2, "status": "failed",
         "action": "ran", "error": "StoreError: disk full", "parameters": {"L": 49.0}},
    ]  # fmt: skip
    write_manifest(tmp_path, {"n_runs": 2}, recs)
    doc = read_manifest(tmp_path)
    assert doc["counts"] == {"complete": 1, "failed": 1, "pending": 0} and doc["runs"] == recs
    rows = list(csv.DictReader((tmp_path / "manifest.csv").open()))
    assert [r["status"] for r in rows] == ["complete", "failed"]
    assert rows[0]["sigma_v_m_s"] == "0.8" and rows[0]["validation"] == "pass" and rows[1]["error"].endswith("full")
    assert json.loads(rows[1]["parameters"]) == {"L": 49.0}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["manifest.csv", "manifest.json"]  # no temp files left


def test_default_cluster_size_follows_cores_runs_and_memory(tmp_path, monkeypatch):
    from turbgen.runs.kaimal import kaimal_generator, memory_needed
    from turbgen.sweep import tasks as runner

    plan = make_plan(out=tmp_path, models=["kaimal"], presets=["neutral"], speeds=[16], seeds=range(1, 7), grid=TINY)
    tasks = [runner.RunTask(r.model, r.run, "x", False, None, False) for r in plan.runs]
    run = plan.runs[0].run
    need = memory_needed(run.grid, sampler=kaimal_generator(run, workers=1).sampler_bytes())  # one thread per run
    monkeypatch.setattr(runner.os, "cpu_count", lambda: 8)
    monkeypatch.setattr(runner, "available_memory_bytes", lambda: None)
    assert runner.default_workers(tasks) == 6  # at most one worker per run
    assert runner.default_workers(tasks[:3]) == 3
    monkeypatch.setattr(runner, "available_memory_bytes", lambda: int(2.5 * need / 0.8))
    assert runner.default_workers(tasks) == 2  # 80 % of the memory holds two runs
    monkeypatch.setattr(runner, "available_memory_bytes", lambda: need // 10)
    assert runner.default_workers(tasks) == 1  # never fewer than one (the run itself checks its memory)


def test_a_memory_budget_no_run_fits_is_refused_before_dir_is_touched(tmp_path):
    """--memory below what any worker needs even out of core (found by the sweep probe: every run failed in its
    worker, exit 1, after DIR and its manifest were written): refused up front; a budget above the in-memory need
    passes the check."""
    from turbgen.runs.mann_outofcore import least_budget_bytes
    from turbgen.sweep import run_sweep

    grid = {"nt": 256, "planes": [0.0, 50.0], "ny": 8, "nz": 8}
    plan = make_plan(out=tmp_path / "sw", models=["mann"], presets=["neutral"], speeds=[12], seeds=[1, 2], grid=grid)
    need = least_budget_bytes(plan.runs[0].run)
    assert 100 * 2**20 < need < 2**30  # the interpreter's floor plus the smallest plan of a tiny run
    with pytest.raises(ParameterError, match="at least"):
        run_sweep(plan, progress=False, memory_bytes=need - 1)
    assert not (tmp_path / "sw").exists()
    from turbgen.sweep.plan import check_memory_budget

    check_memory_budget(plan.runs, need)  # at the bound: not refused (the run itself checks its real need)
