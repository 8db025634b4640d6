"""Constrained Kaimal runs end to end: zero-noise interpolation of the store (point series with gaps, fully observed
series, a virtual-lidar dataset), the store's record with turbgen info / validate, and the CLI's refusals."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.virtual_lidar.dataset import read_dataset
from turbgen.runs.constrain import place
from turbgen.runs.constrain_kaimal import run_kaimal_constrained
from turbgen.spec.constraints import point_series_from_mapping
from turbgen.spec.kaimal import KaimalRun
from turbgen.store import open_store
from turbgen.synthesis import conditioning as cond
from turbgen.synthesis.kaimal_evo import COMPONENTS
from turbgen.validation import validate

GRID = {"nt": 128, "dt_s": 0.5, "x_m": [0.0, 40.0], "ny": 4, "nz": 4, "dy_m": 10.0, "dz_m": 10.0}
SMALL = ["--U", "16", "--nt", "128", "--ny", "4", "--nz", "4", "--dy", "10", "--dz", "10", "--planes", "0,40",
         "--threads", "1"]  # fmt: skip


def _mast(t_s, total=True, U=16.0):
    """A sensor off the grid nodes (bilinear) with u (total wind, one gap) and w, and one on the far plane with v;
    4 Hz data on a 2 Hz field: interpolated."""
    u = U * total + 1.5 * np.sin(t_s / 3.0)
    u[20:25] = np.nan
    return {
        "kind": "point-series", "name": "mast", "time_s": list(t_s), "total_wind": total,
        "sensors": [
            {"name": "hub", "x_m": 0.0, "y_m": 3.0, "z_m": -4.0,
             "u_m_s": [None if math.isnan(v) else v for v in u], "w_m_s": list(0.4 * np.cos(t_s / 2.0))},
            {"name": "gate", "x_m": 40.0, "y_m": -10.0, "z_m": 5.0, "v_m_s": list(0.8 * np.sin(t_s / 5.0 + 1))},
        ],
    }  # fmt: skip


def _bilinear(field, g, y, z):
    """field (nt, ny, nz) at (y, z), bilinear."""
    fy, fz = (y - g.y()[0]) / g.dy_m, (z - g.z()[0]) / g.dz_m
    iy, iz = int(fy), int(fz)
    ay, az = fy - iy, fz - iz
    return ((1 - ay) * (1 - az) * field[:, iy, iz] + ay * (1 - az) * field[:, iy + 1, iz]
            + (1 - ay) * az * field[:, iy, iz + 1] + ay * az * field[:, iy + 1, iz + 1])  # fmt: skip


def _remeasured(fs, placed) -> np.ndarray:
    out = np.zeros(placed.data.shape)
    for c, comp in enumerate(COMPONENTS):
        for ix in range(fs.grid.nx):
            cond.measure(placed.streams, ix, c, fs.read_plane(comp, ix).astype(float), out)
    return out


def _full_record():
    """The hub sensor alone, u without the gap, 4 Hz over the whole record: every stored time observed."""
    t = np.arange(0.0, 63.75, 0.25)
    mapping = _mast(t)
    mapping["sensors"] = mapping["sensors"][:1]
    mapping["sensors"][0]["u_m_s"] = list(16.0 + 1.5 * np.sin(t / 3.0))
    return mapping


@pytest.mark.parametrize("full", [False, True])
def test_zero_noise_store_reproduces_the_data(tmp_path, full):
    """With gaps (missing u, stored times outside the data: conjugate gradients on the exact S) and with every
    sample observed (the direct per-frequency solve), the field reproduces the data minus each full-rate series'
    record mean (the Kaimal field has zero record mean at every point) to 1e-4 m/s."""
    run = KaimalRun.from_mapping({"U_m_s": 16.0, "seed": 3, "grid": GRID})
    mapping = _full_record() if full else _mast(np.arange(0.0, 25.0, 0.25))
    files = [point_series_from_mapping(mapping, "mast.json")]
    summary = run_kaimal_constrained(run, tmp_path / "c.zarr", files, threads=1)
    fs = open_store(tmp_path / "c.zarr")
    placed = place(run, files)
    record = fs.attrs["constraints"]
    removed = np.array(record["record_mean_removed_m_s"])
    obs = np.isfinite(placed.data)
    assert obs.sum() == record["n_samples"] > 60 and obs.all() == full
    np.testing.assert_allclose(removed, [np.mean(r[np.isfinite(r)]) for r in placed.data])
    assert np.abs(removed).max() > 0.05  # the data do have a record mean: removing it is tested
    resid = (_remeasured(fs, placed) - (placed.data - removed[:, None]))[obs]
    assert np.abs(resid).max() < 1e-4, np.abs(resid).max()
    assert record["residual_max_m_s"] < 1e-4 and summary["constraints"] == record
    assert record["solver"]["method"] == ("circulant" if full else "pcg")
    assert "the check applies only when the data came from the same model" in validate(fs, workers=1).table()


LIDAR = {"name": "small", "kind": "pulsed", "mount": "nacelle", "ranges_m": [20, 40], "beam_rate_hz": 1.0,
         "rotor_radius_m": 10, "azimuth_deg": [10, -10], "elevation_deg": [5, -5], "fwhm_m": 4}  # fmt: skip
LIDAR_GRID = ["--U", "16", "--nt", "256", "--ny", "8", "--nz", "8", "--dy", "5", "--dz", "5", "--planes", "0,20,40",
              "--threads", "1"]  # fmt: skip


def test_zero_noise_lidar_loop_remeasures_the_data(tmp_path):
    """truth (Kaimal seed 1) -> `turbgen lidar run` -> Kaimal seed 2 constrained on it (noise 0) -> the virtual lidar
    re-measures the given v_los to 1e-4 m/s (each beam-gate every 4 steps: no record mean is removed)."""
    (tmp_path / "small.json").write_text(json.dumps(LIDAR))
    r = CliRunner()

    def lidar(store, out):
        res = r.invoke(cli, ["lidar", "run", str(tmp_path / store), "--lidar", str(tmp_path / "small.json"),
                             "--rotor-radius", "10", "--mean-wind", "--out", str(tmp_path / out)], prog_name="turbgen")
        assert res.exit_code in (0, 1), res.output  # 1 = the lidar run's coherence verdict, not an error

    res = r.invoke(cli, ["kaimal", *LIDAR_GRID, "--seed", "1", "--out", str(tmp_path / "truth.zarr")],
                   prog_name="turbgen")  # fmt: skip
    assert res.exit_code == 0, res.output
    lidar("truth.zarr", "truth_lidar.zarr")
    t = np.arange(0.0, 127.75, 0.25)  # a full-rate point series too: split into 4 streams every 4 steps
    mast = {"kind": "point-series", "time_s": list(t), "sensors": [
        {"name": "hub", "x_m": 0.0, "y_m": 2.0, "z_m": -3.0, "u_m_s": list(1.5 + np.sin(t / 4.0))}]}  # fmt: skip
    mast_path = _write(tmp_path / "mast.json", mast)
    res = r.invoke(cli, ["kaimal", *LIDAR_GRID, "--seed", "2", "--constrain", str(tmp_path / "truth_lidar.zarr"),
                         "--constrain", mast_path, "--out", str(tmp_path / "c.zarr")], prog_name="turbgen")
    assert res.exit_code == 0, res.output
    lidar("c.zarr", "re.zarr")
    truth, again = read_dataset(tmp_path / "truth_lidar.zarr").v_los, read_dataset(tmp_path / "re.zarr").v_los
    assert np.isfinite(truth).sum() > 20
    np.testing.assert_allclose(again, truth, rtol=0, atol=1e-4)
    fs = open_store(tmp_path / "c.zarr")
    removed = fs.attrs["constraints"]["record_mean_removed_m_s"]
    series = [s["name"] for s in fs.attrs["constraints"]["streams"]]
    assert sum(":hub:" in n for n in series) == 4 and all((":hub:" in n) == (v != 0) for n, v in zip(series, removed))
    u = _bilinear(fs.read_plane("u", 0).astype(float), fs.grid, 2.0, -3.0)
    expected = np.interp(fs.grid.t(), t, 1.5 + np.sin(t / 4.0))
    np.testing.assert_allclose(u, expected - expected.mean(), rtol=0, atol=1e-4)


def _write(path, mapping):
    path.write_text(json.dumps(mapping))
    return str(path)


@pytest.mark.parametrize("case", range(8))
def test_bad_constraints_are_one_line_exit_2_nothing_written(tmp_path, case):
    from test_run import assert_refused, bad_cases

    assert_refused(tmp_path, ["kaimal", *SMALL], bad_cases(_mast(np.arange(0.0, 20.0, 0.5)))[case])


def test_dependent_zero_noise_series_are_refused_and_nothing_written(tmp_path):
    path = _write(tmp_path / "m.json", _mast(np.arange(0.0, 20.0, 0.5)))
    res = CliRunner().invoke(cli, ["kaimal", *SMALL, "--constrain", path, "--constrain", path, "--out",
                                   str(tmp_path / "c.zarr")], prog_name="turbgen")  # fmt: skip
    lines = res.stderr.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1, res.output
    assert "are linearly dependent with zero noise" in lines[0] and "m.json:hub:u" in lines[0], lines[0]
    assert not (tmp_path / "c.zarr").exists()


def test_noise_without_constrain_is_a_usage_error(tmp_path):
    res = CliRunner().invoke(cli, ["kaimal", *SMALL, "--noise", "0.1", "--out", str(tmp_path / "c.zarr")],
                             prog_name="turbgen")  # fmt: skip
    assert res.exit_code == 2 and "--noise and --conditional-mean need --constrain FILE" in res.stderr
    assert not (tmp_path / "c.zarr").exists()


def test_conditional_mean_store_shown_by_info_and_refused_by_validate(tmp_path):
    path = _write(tmp_path / "m.json", _mast(np.arange(0.0, 20.0, 0.5)))
    out = str(tmp_path / "cm.zarr")
    res = CliRunner().invoke(cli, ["kaimal", *SMALL, "--constrain", path, "--noise", "0.2", "--conditional-mean",
                                   "--out", out], prog_name="turbgen")  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "constrained (conditional mean) on 3 measured series" in res.stdout
    info = CliRunner().invoke(cli, ["info", out], prog_name="turbgen")
    assert "constraints  conditional mean on 3 series" in info.stdout and "m.json:gate:v" in info.stdout
    res = CliRunner().invoke(cli, ["validate", out], prog_name="turbgen")
    assert res.exit_code == 2 and "holds the conditional mean of a constrained run" in res.stderr
    fs = open_store(out)
    assert fs.attrs["constraints"]["conditional_mean"] is True and "synthesis_report" in fs.attrs
    # far from the sensors in time (the data end at 20 s; the record is 32 s) the mean decays towards 0
    assert np.abs(fs.read_plane("u", 0)).max() < 5.0
