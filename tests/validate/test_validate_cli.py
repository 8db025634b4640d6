"""`turbgen validate STORE [--json] [--plots DIR] [--rotor-radius R]`: output, exit codes, refusals."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.grid import Grid
from turbgen.runs.kaimal import run_kaimal, store_attrs
from turbgen.spec.kaimal import KaimalRun, kaimal_params
from turbgen.store import create_store, open_store
from turbgen.store.layout import CALLER_ATTRS

GRID = Grid(nt=1024, dt_s=0.5, x_m=(0.0, 30.0), ny=12, nz=12, dy_m=8.0, dz_m=8.0)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "k.zarr"
    run_kaimal(KaimalRun(kaimal=kaimal_params(12.0, "B", 90.0), grid=GRID, U_m_s=12.0, seed=4), path)
    return path


def _run(*args):
    return CliRunner().invoke(cli, ["validate", *map(str, args)])


def test_table_and_exit_0(store):
    r = _run(store, "--rotor-radius", 30)
    assert r.exit_code == 0, r.output
    assert "all metrics pass" in r.output
    for name in ("sigma_u", "spectrum_u", "yz_coherence_u", "longitudinal_coherence_u", "rews_spectrum"):
        assert name in r.output


def test_json_keys_are_stable(store):
    r = _run(store, "--json", "--rotor-radius", 30)
    assert r.exit_code == 0
    d = json.loads(r.output)
    assert d["schema"] == "turbgen-validate/1"
    assert set(d) == {"schema", "store", "model", "passed", "failed", "alpha", "settings", "band", "components",
                      "metrics", "seconds"}
    assert d["model"] == "kaimal" and d["passed"] is True and d["failed"] == []
    assert d["settings"]["rotor_radius_m"] == 30.0 and d["settings"]["rotor_points"] > 0
    assert {"f_min_hz", "f_max_hz", "k1_min_rad_m", "k1_max_rad_m", "note"} <= set(d["band"])
    assert set(d["components"]["u"]) == {"mean_m_s", "sigma_m_s", "sigma_expected_m_s", "sigma_band_m_s",
                                         "sigma_model_m_s", "ti", "ti_expected"}
    m = d["metrics"]["spectrum_u"]
    assert set(m) == {"title", "quantity", "passed", "max_abs_z", "z_crit", "n_tests", "worst", "tests"}
    assert m["n_tests"] == len(m["tests"]) > 0
    assert set(m["worst"]) == {"label", "band_hz", "estimate", "expected", "sigma", "z"}


def test_plots_written(store, tmp_path):
    out = tmp_path / "figs"
    r = _run(store, "--plots", out, "--rotor-radius", 30)
    assert r.exit_code == 0
    names = {p.name for p in out.glob("*.png")}
    assert {"spectrum_u.png", "yz_coherence_u.png", "longitudinal_coherence_u.png", "rews_spectrum.png"} <= names
    assert all((out / n).stat().st_size > 5000 for n in names)


def test_failing_metric_gives_exit_1(store, tmp_path):
    fs = open_store(store)
    bad = tmp_path / "bad.zarr"
    with create_store(bad, fs.grid, {k: fs.attrs[k] for k in CALLER_ATTRS}) as w:
        for c in "uvw":
            for ix in range(fs.grid.nx):
                w.write(c, ix, fs.read_plane(c, ix) * (1.3 if c == "u" else 1.0))
    r = _run(bad, "--json", "--rotor-radius", 30)
    assert r.exit_code == 1
    d = json.loads(r.output)
    # u x 1.3 is a spectrum_u failure (z > 10); sigma_u^2 x 1.8 alone is not significant on this small grid:
    # the top eigen-mode of the lowest line carries 80 % of it (the 88 m grid moves as one at 1 mHz), so its
    # exact law (``variance_law``) puts z = 3.1 < 3.29 (the one-gamma law used before said > 3.29)
    assert d["passed"] is False and "spectrum_u" in d["failed"]
    assert not [m for m in d["failed"] if m.endswith(("_v", "_w"))], d["failed"]


def test_default_rotor_radius_fits_a_small_grid(store):
    # no --rotor-radius: 63 m, or the largest disc inside a smaller grid (here (ny - 1) dy / 2)
    r = _run(store, "--json")
    assert r.exit_code == 0, r.output
    half = min((GRID.ny - 1) * GRID.dy_m, (GRID.nz - 1) * GRID.dz_m) / 2
    assert json.loads(r.output)["settings"]["rotor_radius_m"] == pytest.approx(min(63.0, half))


def test_usage_errors_give_exit_2(store, tmp_path):
    r = _run(tmp_path / "missing.zarr")
    assert r.exit_code == 2 and "no such store" in r.output
    r = _run(store, "--rotor-radius", 500)
    assert r.exit_code == 2 and "rotor radius" in r.output
    incomplete = tmp_path / "inc.zarr"
    incomplete.mkdir()
    (incomplete / "zarr.json").write_text(json.dumps({"node_type": "group", "zarr_format": 3,
                                                       "attributes": {"turbgen_version": "0"}}))
    r = _run(incomplete)
    assert r.exit_code == 2 and "incomplete" in r.output
    r = _run(store, "--rotor-radius", "abc")
    assert r.exit_code == 2
    r = _run(store, "--rotor-radius", 0.1)  # inside the grid but below the README's range of rotor radii
    assert r.exit_code == 2 and "[0.5, 500]" in r.output


def test_white_noise_store_fails(tmp_path):
    # a store whose attributes say Kaimal but whose data are white noise of the right variance
    run = KaimalRun(kaimal=kaimal_params(12.0, "B", 90.0), grid=GRID, U_m_s=12.0, seed=4)
    attrs = store_attrs(run)
    rng = np.random.default_rng(3)
    path = tmp_path / "white.zarr"
    with create_store(path, GRID, attrs) as w:
        for i, c in enumerate("uvw"):
            for ix in range(GRID.nx):
                sigma = attrs["derived"]["expected_sigma_m_s"][i]
                w.write(c, ix, rng.standard_normal((GRID.nt, GRID.ny, GRID.nz)) * sigma)
    r = _run(path, "--json", "--rotor-radius", 30)
    assert r.exit_code == 1
    assert {"spectrum_u", "yz_coherence_u"} <= set(json.loads(r.output)["failed"])


@pytest.mark.parametrize("ny,nz,dy,dz", [(2, 2, 5.0, 5.0), (4, 4, 2.0, 10.0)])
def test_default_rotor_radius_holds_a_grid_point(tmp_path, ny, nz, dy, dz):
    # grids the generators accept where the largest disc inside the grid holds no grid point: the
    # default radius reaches the nearest points instead of refusing a radius the user never gave
    grid = Grid(nt=256, dt_s=0.5, x_m=(0.0,), ny=ny, nz=nz, dy_m=dy, dz_m=dz)
    path = tmp_path / "k.zarr"
    run_kaimal(KaimalRun(kaimal=kaimal_params(12.0, "B", 90.0), grid=grid, U_m_s=12.0, seed=4), path)
    r = _run(path, "--json")
    assert r.exit_code == 0, r.output
    settings = json.loads(r.output)["settings"]
    nearest = np.hypot(grid.y(), grid.z()[:, None]).min()
    assert settings["rotor_radius_m"] == pytest.approx(nearest)
    assert settings["rotor_points"] == 4  # the nearest points: (+-dy/2, +-dz/2), (+-1, +-5) m


def test_fully_coherent_plane_validates(tmp_path):
    # a_yz = 0 (allowed: [0, 1e4]) makes u coherent over each plane; on 5 x 5 x 2 points validate raised
    # numpy's LinAlgError (a traceback), then, with the modes computed, scored sigma_u^2 8.24 vs 5.74 (sd 2.1)
    # at z = 37 from the modes' rounding residue
    grid = Grid(nt=256, dt_s=0.5, x_m=(0.0, 40.0), ny=5, nz=5, dy_m=5.0, dz_m=5.0)
    path = tmp_path / "k.zarr"
    run_kaimal(KaimalRun(kaimal=kaimal_params(16.0, "A", 90.0, a_yz=0.0), grid=grid, U_m_s=16.0, seed=1), path)
    r = _run(path, "--json")
    assert r.exit_code == 0, r.output
    assert abs(json.loads(r.output)["metrics"]["sigma_u"]["max_abs_z"]) < 3
