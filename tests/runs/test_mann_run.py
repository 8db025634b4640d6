"""`turbgen mann` and turbgen.runs.mann: store layout, defaults, determinism, bad input, interruption."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.runs import mann as runs_mann
from turbgen.spec.defaults import DEFAULT_PLANES_M
from turbgen.runs.mann import build_mann_stencil, run_mann
from turbgen.spec.mann import MannRun
from turbgen.store import open_store
from turbgen.synthesis.mann_spacetime import MannSnapshots
from turbgen.theory.kaimal import iec_sigma1_m_s
from turbgen.theory.mann_spectra import ae_for_sigma_u

SMALL = {"nt": 64, "ny": 6, "nz": 5, "x_m": [0.0, 50.0, 100.0]}
SMALL_ARGS = ["--nt", "64", "--ny", "6", "--nz", "5", "--planes", "0,50,100"]


def small_run(**kw) -> MannRun:
    return MannRun.from_mapping({"grid": SMALL, **kw})


def test_defaults_are_the_paper_case():
    run = MannRun.from_mapping({})
    g = run.grid
    assert (g.nt, g.dt_s, g.ny, g.nz, g.dy_m, g.dz_m) == (4096, 0.5, 64, 64, 4.7, 4.7)
    assert g.x_m == DEFAULT_PLANES_M and len(g.x_m) == 11 and g.x_m[-1] == pytest.approx(169.7)
    p = run.params
    assert (p.length_scale_m, p.gamma, p.evo_time_s, p.lifetime, run.U_m_s, run.seed) == (49, 3.1, 400, "guo", 16, 1)
    assert (run.hub_height_m, run.pad_yz) == (150.0, 2)
    assert p.ae == pytest.approx(ae_for_sigma_u(iec_sigma1_m_s(16.0, "A"), p), rel=1e-12)
    assert 290 < g.ny * g.dy_m < 310  # a ~300 m wide box
    # ... that stays above the ground at the default hub height (exports need hub + z > 0)
    assert 150.0 + g.z()[0] > 0
    assert run.default_store_name() == "mann_U16_L49_G3.1_evo400_s1.zarr"


def test_energy_level_precedence():
    base = small_run()
    assert small_run(ae=0.2).params.ae == 0.2
    assert small_run(sigma_u_m_s=2.0).params.ae == pytest.approx(ae_for_sigma_u(2.0, base.params), rel=1e-12)
    assert small_run(ti=0.125).params.ae == pytest.approx(ae_for_sigma_u(2.0, base.params), rel=1e-12)
    assert small_run(ae=0.2, sigma_u_m_s=2.0).params.ae == 0.2


def test_store_layout_summary_and_mapping_roundtrip(tmp_path):
    run = small_run(seed=3)
    s = run_mann(run, tmp_path / "a.zarr", threads=1)
    fs = open_store(tmp_path / "a.zarr")
    assert fs.model == "mann" and fs.attrs["seed"] == 3 and fs.U_m_s == 16.0 and fs.hub_height_m == 150.0
    assert fs.attrs["frame"] == "convected" and fs.attrs["turbgen_complete"] is True
    assert fs.array("u").shape == (64, 3, 6, 5) and fs.array("u").dtype == np.float32
    ds = xr.open_zarr(tmp_path / "a.zarr")
    assert ds["w"].dims == ("t", "x", "y", "z") and list(ds["x"].values) == [0.0, 50.0, 100.0]
    for c in "uvw":
        data = fs.array(c)[...].astype(float)
        assert s[f"sigma_{c}"] == pytest.approx(data.std(), rel=1e-5)
        assert s[f"mean_{c}"] == pytest.approx(data.mean(), abs=1e-5 * data.std())
    # the stored parameters (inputs), derived values and grid rebuild the same run
    assert "ae_from" not in fs.attrs["parameters"] and fs.attrs["derived"]["ae_from"] == run.ae_from
    again = MannRun.from_attrs(fs.attrs)
    assert again == run
    # planes differ (evolution) but are strongly correlated 50 m apart (tau_e >> 50/16 s at large scales)
    u = fs.array("u")[...].astype(float)
    r01 = np.corrcoef(u[:, 0].ravel(), u[:, 1].ravel())[0, 1]
    assert 0.3 < r01 < 0.999


def test_identical_for_any_chunking_threads_and_given_stencil(tmp_path):
    run = small_run(seed=5)
    run_mann(run, tmp_path / "a.zarr", chunk_t=16, threads=1)
    run_mann(run, tmp_path / "b.zarr", chunk_t=64, threads=2, stencil=build_mann_stencil(run))
    a, b = open_store(tmp_path / "a.zarr"), open_store(tmp_path / "b.zarr")
    assert a.array("u").chunks != b.array("u").chunks
    for c in "uvw":
        assert np.array_equal(a.array(c)[...], b.array(c)[...])


def test_a_stencil_of_other_parameters_is_refused(tmp_path):
    with pytest.raises(ValueError, match="stencil"):
        run_mann(small_run(gamma=2.0), tmp_path / "a.zarr", stencil=build_mann_stencil(small_run()))
    one_plane = MannRun.from_mapping({"grid": {**SMALL, "x_m": [0.0]}})
    with pytest.raises(ValueError, match="evolving=False"):
        run_mann(small_run(), tmp_path / "a.zarr", stencil=build_mann_stencil(one_plane))
    assert build_mann_stencil(one_plane).inv_tau is None
    assert not (tmp_path / "a.zarr").exists()


def test_interruption_leaves_no_store(tmp_path, monkeypatch):
    real = MannSnapshots.generate

    def broken(self, seed, times, **options):
        for n, item in enumerate(real(self, seed, times, **options)):
            if n == 4:
                raise KeyboardInterrupt
            yield item

    monkeypatch.setattr(MannSnapshots, "generate", broken)
    with pytest.raises(KeyboardInterrupt):
        run_mann(small_run(), tmp_path / "x.zarr", threads=1)
    assert list(tmp_path.iterdir()) == []


def test_cli_runs_and_prints_plan_and_summary(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(cli, ["mann", "--L", "49", "--gamma", "3.1", "--evo", "400", *SMALL_ARGS])
    assert res.exit_code == 0, res.output
    # a grid other than the default: the readable name plus a digest of parameters and grid
    (name,) = [p.name for p in tmp_path.iterdir() if p.name.startswith("mann_U16_L49_G3.1_evo400_s1_p")]
    assert "grid: 64 x 3 x 6 x 5" in res.output and "memory" in res.output and name in res.output
    assert "sigma u/v/w" in res.output.splitlines()[-1]
    assert open_store(tmp_path / name).attrs["parameters"]["gamma"] == 3.1


def test_cli_config_file_with_overrides(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "run.toml").write_text(
        'length_scale_m = 30.0\ngamma = 2.0\nseed = 4\nevo_time_s = 200.0\n[grid]\nnt = 64\nny = 4\nnz = 4\n'
        "x_m = [0.0, 40.0]\n"
    )
    res = CliRunner().invoke(cli, ["mann", "--config", "run.toml", "--gamma", "2.5", "--out", "c.zarr"])
    assert res.exit_code == 0, res.output
    p = open_store(tmp_path / "c.zarr").attrs["parameters"]
    assert (p["length_scale_m"], p["gamma"], p["seed"], p["evo_time_s"]) == (30.0, 2.5, 4, 200.0)
    (tmp_path / "run.json").write_text(json.dumps({"evo_time_s": None, "grid": {"nt": 32, "ny": 3, "nz": 3}}))
    res = CliRunner().invoke(cli, ["mann", "--config", "run.json", "--planes", "0,10", "--out", "f.zarr"])
    assert res.exit_code == 0, res.output
    fs = open_store(tmp_path / "f.zarr")
    assert fs.attrs["parameters"]["evo_time_s"] is None
    assert np.array_equal(fs.array("u")[:, 0], fs.array("u")[:, 1])  # frozen: identical planes


@pytest.mark.parametrize(
    "args, words",
    [
        (["--L", "-1"], "L (length scale"),
        (["--nt", "1"], "nt"),
        (["--gamma", "40"], "gamma"),
        (["--ae", "1", "--ti", "0.1"], "one of --ae"),
        (["--ti", "1.5"], "ti"),
        (["--planes", "0,50,50"], "duplicate"),
        (["--planes", "0,50", "--gates", "50:60:5"], "not both"),
        (["--gates", "50:10:5"], "gates"),
        (["--pad-yz", "0"], "pad-yz"),
        (["--evo", "soon"], "frozen"),
        (["--lifetime", "bogus"], "lifetime"),
        (["--U", "0"], "U (mean wind speed"),
        (["--threads", "0"], "threads"),
        (["--seed", "-2"], "seed"),
    ],
)
def test_cli_bad_input_one_line_exit_2_nothing_written(tmp_path, monkeypatch, args, words):
    monkeypatch.chdir(tmp_path)
    planes = [] if "--planes" in args or "--gates" in args else ["--planes", "0,50"]
    res = CliRunner().invoke(cli, ["mann", "--nt", "64", "--ny", "6", "--nz", "5", *planes, *args])
    assert res.exit_code == 2, res.output
    assert words in res.output
    assert list(tmp_path.iterdir()) == []


def test_cli_bad_config_files(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.json").write_text(json.dumps({"Lx": 3}))
    (tmp_path / "b.json").write_text(json.dumps({"gamma": "high"}))
    (tmp_path / "c.toml").write_text("gamma = [")
    for name, words in (("a.json", "Lx"), ("b.json", "gamma"), ("c.toml", "TOML")):
        res = CliRunner().invoke(cli, ["mann", "--config", name])
        assert res.exit_code == 2 and words in res.output, res.output
        assert len(res.output.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "b.json", "c.toml"]


def test_cli_existing_store_and_memory_check(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert CliRunner().invoke(cli, ["mann", *SMALL_ARGS, "--out", "s.zarr"]).exit_code == 0
    before = open_store(tmp_path / "s.zarr").attrs["created_utc"]
    res = CliRunner().invoke(cli, ["mann", *SMALL_ARGS, "--out", "s.zarr", "--seed", "9"])
    assert res.exit_code == 2 and "--overwrite" in res.output
    assert open_store(tmp_path / "s.zarr").attrs["created_utc"] == before
    res = CliRunner().invoke(cli, ["mann", *SMALL_ARGS, "--out", "s.zarr", "--seed", "9", "--overwrite"])
    assert res.exit_code == 0 and open_store(tmp_path / "s.zarr").attrs["seed"] == 9
    monkeypatch.setattr("turbgen.resources.available_memory_bytes", lambda *a, **k: 10 * 2**20)
    res = CliRunner().invoke(cli, ["mann", *SMALL_ARGS, "--out", "m.zarr"])
    assert res.exit_code == 2 and "--pad-yz" in res.output and "memory" in res.output
    assert not (tmp_path / "m.zarr").exists()


def test_memory_estimate_scales_with_one_snapshot():
    two = MannRun.from_mapping({"grid": {"x_m": [0.0, 50.0]}})
    eleven = MannRun.from_mapping({})
    est2, est11 = (runs_mann.memory_estimate_bytes(r, 2) for r in (two, eleven))
    assert est2 == est11 and est11 < 2 * 2**30  # the paper case fits the 2 GiB target
    one = runs_mann.memory_estimate_bytes(MannRun.from_mapping({"grid": {"x_m": [0.0]}}), 2)
    # one snapshot: no OU state, no stored stencil (5 float32 per stored point, with its 64 MiB of building
    # temporaries) but two threads' on-demand coefficients of a task of 16 slabs (48 bytes per stored point), and one
    # output plane instead of two (components 1 and 2 go into spectra already transformed)
    state, stencil, batches = 3 * 2049 * 128 * 128 * 8, 2049 * 65 * 128 * 4 * 5 + 64 * 2**20, 2 * 16 * 65 * 128 * 48
    assert math.isclose(one, est11 - state - stencil + batches - 4096 * 64 * 64 * 4)


def test_a_single_snapshot_computes_its_stencil_on_demand(tmp_path, monkeypatch):
    one_plane = MannRun.from_mapping({"grid": {**SMALL, "x_m": [0.0]}})
    made = []
    original = runs_mann.build_stencil
    monkeypatch.setattr(runs_mann, "build_stencil", lambda *a, **k: made.append(original(*a, **k)) or made[-1])
    run_mann(one_plane, tmp_path / "a.zarr")
    assert len(made) == 1 and made[0].coef is None  # no stored coefficients
    run_mann(one_plane, tmp_path / "b.zarr", stencil=build_mann_stencil(one_plane))  # a stored stencil
    assert made[-1].coef is not None
    a, b = open_store(tmp_path / "a.zarr"), open_store(tmp_path / "b.zarr")
    for c in "uvw":
        assert np.array_equal(a.array(c)[...].view(np.uint32), b.array(c)[...].view(np.uint32))
