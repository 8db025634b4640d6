"""Constraints through the Python API and the run spec: turbgen.mann(constrain=...) is the field of
`turbgen mann --constrain` to the bit, a run file's `constrain` keys are the options, store names carry a digest of
the data, the service takes uploads by id, never paths."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import turbgen
from turbgen.cli import cli
from turbgen.errors import ParameterError

MAST = Path(__file__).parents[2] / "examples" / "mast.json"
SMALL = {"U": 12, "nt": 64, "ny": 6, "nz": 6, "dy": 8, "planes": [0, 40], "pad_yz": 1, "seed": 2, "threads": 1}
SMALL_CLI = ["--U", "12", "--nt", "64", "--ny", "6", "--nz", "6", "--dy", "8", "--planes", "0,40", "--pad-yz", "1",
             "--seed", "2", "--threads", "1"]  # fmt: skip


def _fields(ds):
    return np.stack([ds[c].values for c in "uvw"])


@pytest.mark.parametrize("mean", [False, True])
def test_api_equals_the_cli_to_the_bit(tmp_path, mean, monkeypatch):
    import turbgen.api.fields as fields

    out = tmp_path / "cli.zarr"
    flags = ["--conditional-mean"] if mean else []
    res = CliRunner().invoke(cli, ["mann", *SMALL_CLI, "--constrain", str(MAST), "--noise", "0.1", *flags,
                                   "--out", str(out)])  # fmt: skip
    assert res.exit_code == 0, res.output
    with monkeypatch.context() as m:  # in memory: no temporary store
        m.setattr(fields, "_through_store", lambda *a: pytest.fail("went through a store"))
        api = turbgen.mann(**SMALL, constrain=[MAST], noise=0.1, conditional_mean=mean)
    store = turbgen.open_store(out)
    cli_field = _fields(store)
    np.testing.assert_array_equal(_fields(api), cli_field)
    assert api.attrs["constraints"]["conditional_mean"] is mean
    differ = {k for k in set(api.attrs) | set(store.attrs) if api.attrs.get(k) != store.attrs.get(k)}
    assert differ <= {"created_utc"}, differ  # the Dataset the store opens to, made without a store
    # a budget too small for the field in memory: made through a temporary store, the same field
    np.testing.assert_array_equal(_fields(turbgen.mann(**SMALL, constrain=[MAST], noise=0.1, conditional_mean=mean,
                                                       memory=2**20)), cli_field)  # fmt: skip
    # a constraint loaded beforehand is the same constraint
    from turbgen.runs.constrain import load_constraint

    loaded = turbgen.mann(**SMALL, constrain=[load_constraint(MAST)], noise=0.1, conditional_mean=mean)
    np.testing.assert_array_equal(_fields(loaded), cli_field)
    plain = _fields(turbgen.mann(**SMALL))
    assert not np.array_equal(plain, cli_field)  # the constraint changed the field


def test_run_file_keys_are_the_options(tmp_path, monkeypatch):
    """A run file's constrain (relative to the file), noise_m_s and conditional_mean = the typed options; the default
    store name carries the data's digest, not the path: a copy of the file gives the same name, other data another."""
    data_dir = tmp_path / "data"
    data_dir.mkdir()
    shutil.copy(MAST, data_dir / "m.json")
    run_file = tmp_path / "run.json"
    run_file.write_text(json.dumps({"U_m_s": 12, "seed": 2, "pad_yz": 1, "ti": 0.15, "constrain": ["data/m.json"],
                                    "noise_m_s": 0.1, "grid": {"nt": 64, "ny": 6, "nz": 6, "dy_m": 8,
                                                               "x_m": [0, 40]}}))  # fmt: skip
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)  # the run file's paths are relative to it, not to the working directory
    res = CliRunner().invoke(cli, ["mann", "--config", str(run_file), "--threads", "1"])
    assert res.exit_code == 0, res.output
    (name,) = [p.name for p in work.glob("*.zarr")]
    assert name.startswith("mann_U12_L49_G3.1_evo400_s2_p") and "_c" in name
    from_file = _fields(turbgen.open_store(work / name))
    np.testing.assert_array_equal(from_file, _fields(turbgen.mann(config=run_file, threads=1)))
    np.testing.assert_array_equal(from_file, _fields(turbgen.mann(**SMALL, ti=0.15, constrain=[MAST], noise=0.1)))

    from turbgen.runs.constrain import constrained_store_name, load_constraints, place
    from turbgen.spec.mann import MannRun

    run = MannRun.from_mapping({"U_m_s": 12, "seed": 2, "pad_yz": 1, "ti": 0.15, "grid": {"nt": 64, "ny": 6, "nz": 6,
                                                                               "dy_m": 8, "x_m": [0, 40]}})  # fmt: skip
    names = {constrained_store_name(run, place(run, load_constraints([f]), 0.1), False)
             for f in (MAST, data_dir / "m.json")}
    assert names == {name}
    other = json.loads(MAST.read_text())
    other["sensors"][0]["w_m_s"][3] += 0.01
    (data_dir / "o.json").write_text(json.dumps(other))
    assert constrained_store_name(run, place(run, load_constraints([data_dir / "o.json"]), 0.1), False) != name
    assert constrained_store_name(run, place(run, load_constraints([MAST]), 0.1), True) != name
    assert run.default_store_name() != name


def test_noise_without_constrain_is_refused(tmp_path):
    with pytest.raises(ParameterError, match="needs constraints"):
        turbgen.mann(**SMALL, noise=0.1)
    with pytest.raises(ParameterError, match="noise = -1 m/s"):
        turbgen.mann(**SMALL, constrain=[MAST], noise=-1)
    res = CliRunner().invoke(cli, ["mann", *SMALL_CLI, "--conditional-mean", "--out", str(tmp_path / "x.zarr")])
    assert res.exit_code == 2 and "needs constraints" in res.output and not (tmp_path / "x.zarr").exists()


def test_service_takes_upload_ids_not_paths():
    from turbgen.service.run_ids import build_run, canonical_mapping, run_from_canonical

    with pytest.raises(ParameterError, match="constrain.*takes the id of uploaded measurements.*not a file"):
        build_run({"model": "mann", "constrain": ["/etc/passwd"]})
    with pytest.raises(ParameterError, match="needs constraints"):
        build_run({"model": "mann", "noise_m_s": 0.1})
    with pytest.raises(ParameterError, match="'constrain' was unexpected"):  # the sweep and service condition Mann
        build_run({"model": "kaimal", "constrain": ["0" * 24]})
    model, run, keys = build_run({"model": "mann", "seed": 3, "constrain": ["ab" * 12], "noise_m_s": 0.2})
    # canonical: conditional_mean only when true; no energy level given: ae from the data, as the CLI
    assert keys == {"constrain": ["ab" * 12], "noise_m_s": 0.2, "energy_from_data": True}
    mapping = canonical_mapping(run, keys)
    assert "ae" not in mapping and mapping["energy_from_data"] is True
    assert run_from_canonical(model, mapping) == (run, keys)  # a restarted server re-queues the same request
    _, run, keys = build_run({"model": "mann", "ti": 0.1, "constrain": ["ab" * 12], "conditional_mean": True})
    assert keys == {"constrain": ["ab" * 12], "conditional_mean": True}
    assert run_from_canonical(model, canonical_mapping(run, keys)) == (run, keys)
    assert build_run({"model": "mann", "seed": 3})[2] == {}


def test_sweep_conditions_every_run_on_the_same_files(tmp_path):
    """A sweep file's constrain keys: every Mann run is `turbgen mann --preset P --U U --seed S --constrain` to the
    bit, under a store name that differs from the unconstrained run's by the digest of the data."""
    import logging

    from distributed import Client, LocalCluster

    from turbgen.sweep import plan_from_mapping, run_sweep

    shutil.copy(MAST, tmp_path / "m.json")
    sweep = {"out": "sw", "models": ["mann"], "presets": ["neutral"], "speeds": [12.0], "seeds": [1, 2],
             "grid": {"nt": 64, "planes": [0.0, 40.0], "ny": 4, "nz": 4, "dy": 8.0}, "constrain": ["m.json"],
             "noise_m_s": 0.1}  # fmt: skip
    plan = plan_from_mapping(sweep, base_dir=tmp_path)
    plain = plan_from_mapping({k: v for k, v in sweep.items() if k not in ("constrain", "noise_m_s")},
                              base_dir=tmp_path)  # fmt: skip
    names = [r.store_name for r in plan.runs]
    assert all(n.startswith("mann_neutral_U12_seed") and "_c" in n for n in names)
    assert not set(names) & {r.store_name for r in plain.runs}
    assert plan.to_dict()["constraints"]["noise_m_s"] == 0.1
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:  # fmt: skip
        result = run_sweep(plan, client=client, progress=False, stencil_cache=tmp_path / "cache")
    assert result.ok
    # the seeds shared one system (the key has no seed); the fields are the uncached command's, below
    assert len(list((tmp_path / "cache").glob("mann-stencil-system-*.npy"))) == 1
    single = tmp_path / "single.zarr"
    res = CliRunner().invoke(cli, ["mann", "--preset", "neutral", "--U", "12", "--seed", "2", "--nt", "64",
                                   "--planes", "0,40", "--ny", "4", "--nz", "4", "--dy", "8", "--threads", "1",
                                   "--constrain", str(MAST), "--noise", "0.1", "--out", str(single)])  # fmt: skip
    assert res.exit_code == 0, res.output
    swept = turbgen.open_store(tmp_path / "sw" / names[1])
    np.testing.assert_array_equal(_fields(swept), _fields(turbgen.open_store(single)))
    assert swept.attrs["constraints"]["n_samples"] == 128
    with pytest.raises(ParameterError, match="Mann runs only"):
        plan_from_mapping({**sweep, "models": ["mann", "kaimal"]}, base_dir=tmp_path)
    res = CliRunner().invoke(cli, ["sweep", "--model", "mann", "--preset", "neutral", "--speeds", "12", "--seeds", "1",
                                   "--out", str(tmp_path / "plain"), "--stencil-cache", str(tmp_path / "c2")])
    assert res.exit_code == 2 and "--stencil-cache is for a sweep with constrain" in res.output
    assert not (tmp_path / "plain").exists() and not (tmp_path / "c2").exists()


@pytest.mark.parametrize("noise", [0.0, 0.1])
def test_energy_level_estimated_from_the_data(tmp_path, noise):
    """No ae, sigma_u, ti or class: ae is estimated from the data. Data drawn from the model (a field of known ae
    read at grid nodes, plus noise of the stated sigma) are N(0, S(a)), so d^T S(a)^-1 d ~ chi^2_n and the estimate's
    relative standard deviation is sqrt(2 / n) (exactly without noise; to first order with noise much smaller than
    the signal): 4 of them."""
    from turbgen.spec.constraints import point_series_from_mapping

    grid = dict(U=12, nt=64, ny=6, nz=6, dy=8, planes=[0, 40], pad_yz=1, threads=1)
    truth = turbgen.mann(seed=5, sigma_u=1.7, **grid)
    rng = np.random.default_rng(11)
    sensors = []
    for iy, iz, x in [(1, 1, 0), (4, 2, 0), (2, 4, 1), (3, 3, 1)]:
        s = {"name": f"p{iy}{iz}{x}", "x_m": float(truth.x[x]), "y_m": float(truth.y[iy]), "z_m": float(truth.z[iz])}
        for c in "uvw":
            s[f"{c}_m_s"] = list(truth[c].values[:, x, iy, iz].astype(float) + noise * rng.standard_normal(64))
        sensors.append(s)
    t = truth.t.values
    # a sensor at x is the stored sample t + x / U: its physical times are t - x / U; keep the ones in the record
    series = []
    for s in sensors:
        lead = s["x_m"] / 12.0
        keep = t - lead >= 0
        comps = {f"{c}_m_s": list(np.asarray(s[f"{c}_m_s"])[keep]) for c in "uvw"}
        series.append(point_series_from_mapping({"kind": "point-series", "time_s": list(t[keep] - lead),
                                                 "noise_m_s": noise, "sensors": [{**s, **comps}]}, s["name"]))
    c = turbgen.mann(seed=6, constrain=series, **grid)
    n = c.attrs["constraints"]["n_samples"]
    ae_true, ae_hat = truth.attrs["parameters"]["ae"], c.attrs["parameters"]["ae"]
    assert c.attrs["derived"]["ae_from"].startswith("estimated from the constraint data")
    assert abs(ae_hat / ae_true - 1) <= 4 * np.sqrt(2 / n), (ae_hat, ae_true, n)
    given = turbgen.mann(seed=6, constrain=series, sigma_u=1.7, **grid)
    assert given.attrs["parameters"]["ae"] == ae_true  # a given level is used as given
