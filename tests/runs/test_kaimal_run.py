"""`turbgen kaimal` and turbgen.runs.kaimal: store contents, determinism across chunkings, bad inputs."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.spec.defaults import DEFAULT_PLANES_M
from turbgen.runs.kaimal import run_kaimal
from turbgen.spec.defaults import DEFAULT_A_X, DEFAULT_B_X
from turbgen.spec.kaimal import KaimalRun, kaimal_params
from turbgen.store import open_store

TINY = ["--nt", "128", "--ny", "4", "--nz", "3", "--dy", "10", "--planes", "0,50,63.3"]


def _run(**kw):
    g = Grid(128, 0.5, (0.0, 50.0, 63.3), 4, 3, 10.0, 10.0)
    return KaimalRun(kaimal_params(16.0, "A", 90.0), g, 16.0, 4, turb_class="A", **kw)


def test_defaults_are_the_paper_case():
    run = KaimalRun.from_mapping({})
    g = run.grid
    assert (g.nt, g.dt_s, g.ny, g.nz, g.dy_m, g.dz_m) == (4096, 0.5, 31, 31, 5.0, 5.0)
    assert g.x_m == tuple(DEFAULT_PLANES_M) and g.nx == 11
    assert (run.U_m_s, run.seed, run.hub_height_m, run.long_model) == (16.0, 1, 150.0, "exp")
    assert (run.a_x, run.b_x) == (DEFAULT_A_X, DEFAULT_B_X) == (1.8, 1.49e-4)
    k = run.kaimal
    assert k.length_scales_m[0] == pytest.approx(8.1 * 42) and k.lc_m == pytest.approx(8.1 * 42) and k.a_yz == 12
    assert k.sigma_m_s[0] == pytest.approx(0.16 * (0.75 * 16 + 5.6))


def test_store_attrs_round_trip_and_chunking_independence(tmp_path):
    run = _run()
    a = run_kaimal(run, tmp_path / "a.zarr")
    b = run_kaimal(run, tmp_path / "b.zarr", chunk_t=16, threads=1)
    fa, fb = open_store(a["path"]), open_store(b["path"])
    assert fa.model == "kaimal" and fb.chunk_t == 16
    for c in "uvw":
        assert np.array_equal(fa.array(c)[:], fb.array(c)[:])
    # the store's parameters + grid rebuild the same run
    rebuilt = KaimalRun.from_mapping({**fa.attrs["parameters"], "grid": fa.attrs["grid"]})
    assert rebuilt == run
    assert a["yz_clip_error"] == 0.0 and a["long_clip_error"] == 0.0
    # the synthesis report (clipping errors) is stored with the field, not only printed
    assert fa.attrs["synthesis_report"]["yz_clip_error"] == 0.0
    assert fa.attrs["synthesis_report"]["max_torus"] == a["max_torus"]
    u = fa.array("u")[:]
    assert a["sigma_u"] == pytest.approx(float(np.sqrt((u.astype(np.float64) ** 2).mean())), rel=1e-6)


def test_cli_writes_the_same_field_as_the_library(tmp_path):
    out = tmp_path / "cli.zarr"
    res = CliRunner().invoke(cli, ["kaimal", *TINY, "--seed", "4", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "memory" in res.output and "wrote" in res.output
    lib = run_kaimal(_run(), tmp_path / "lib.zarr")
    for c in "uvw":
        assert np.array_equal(open_store(out).array(c)[:], open_store(lib["path"]).array(c)[:])


def test_cli_config_and_typed_override(tmp_path):
    cfg = tmp_path / "run.json"
    cfg.write_text(json.dumps({"U_m_s": 12.0, "long_model": "kristensen", "seed": 9,
                               "grid": {"nt": 64, "ny": 3, "nz": 3, "dy_m": 8.0, "x_m": [0, 40]}}))
    out = tmp_path / "c.zarr"
    res = CliRunner().invoke(cli, ["kaimal", "--config", str(cfg), "--seed", "2", "--rescale", "--out", str(out)])
    assert res.exit_code == 0, res.output
    fs = open_store(out)
    p = fs.attrs["parameters"]
    assert (p["U_m_s"], p["long_model"], p["seed"], p["rescale"]) == (12.0, "kristensen", 2, True)
    assert fs.grid == Grid(64, 0.5, (0.0, 40.0), 3, 3, 8.0, 8.0)
    assert fs.attrs["derived"]["expected_sigma_m_s"] == pytest.approx(p["sigma_m_s"], rel=1e-12)  # rescaled to nominal


@pytest.mark.parametrize(
    "args",
    [
        ["--U", "-3"],
        ["--class", "D"],
        ["--sigma", "1,2"],
        ["--seed", "-1"],
        ["--nt", "1"],
        ["--planes", "0,50,50"],
        ["--long-model", "kristensen", "--ax", "2"],
        ["--ax", "0"],
        ["--bx", "-1e-4"],
        ["--lengths", "340,113,0"],
        ["--ayz", "-1"],
        ["--planes", "0,50", "--gates", "50:60:10"],
        ["--long-components", "uv"],
    ],
)
def test_bad_inputs_exit_2_and_write_nothing(tmp_path, args):
    out = tmp_path / "bad.zarr"
    res = CliRunner().invoke(cli, ["kaimal", *TINY, *args, "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_existing_store_needs_overwrite(tmp_path):
    out = tmp_path / "k.zarr"
    assert CliRunner().invoke(cli, ["kaimal", *TINY, "--out", str(out)]).exit_code == 0
    before = open_store(out).array("u")[:]
    res = CliRunner().invoke(cli, ["kaimal", *TINY, "--seed", "5", "--out", str(out)])
    assert res.exit_code == 2 and "overwrite" in res.output
    assert np.array_equal(open_store(out).array("u")[:], before)
    assert CliRunner().invoke(cli, ["kaimal", *TINY, "--seed", "5", "--out", str(out), "--overwrite"]).exit_code == 0
    assert not np.array_equal(open_store(out).array("u")[:], before)


def test_run_validation():
    with pytest.raises(ParameterError, match="long_model"):
        _run(long_model="taylor")
    with pytest.raises(ParameterError, match="a_x"):
        _run(long_model="simley-pao", a_x=1.0)
    with pytest.raises(ParameterError, match="unknown keys"):
        KaimalRun.from_mapping({"U": 16})


def test_small_grid_with_long_range_coherence_takes_dense_factors(tmp_path, monkeypatch):
    """a_yz = 0.5 on 5 x 5 points: every bin is sampled with a 25 x 25 factor, which the memory estimate counts,
    instead of tori of up to ~10^6 points (the estimate with tori, rule switched off: > 10 x larger)."""
    from turbgen.runs.kaimal import kaimal_generator
    from turbgen.synthesis import circulant

    run = KaimalRun.from_mapping({"a_yz": 0.5, "grid": {"nt": 1024, "ny": 5, "nz": 5, "x_m": [0.0, 50.0]}})
    dense = kaimal_generator(run, workers=2).sampler_bytes()
    s = run_kaimal(run, tmp_path / "k.zarr", threads=2)
    assert s["dense_factor_bins"] == 512 and s["max_torus"] == [1, 1]  # every bin of nt / 2; no circulant bin
    assert open_store(tmp_path / "k.zarr").attrs["synthesis_report"]["dense_factor_bins"] == 512
    monkeypatch.setattr(circulant, "dense_is_cheaper", lambda n, m: False)
    assert kaimal_generator(run, workers=2).sampler_bytes() > 10 * dense
