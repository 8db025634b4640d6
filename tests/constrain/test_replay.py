"""Replay a measured event (issue 38 §2): `turbgen mann --constrain DATA --fit` fits the Mann model and the mean wind
to the mast of examples/mast-fit.json, then conditions the field on the same data with them. The field passes
through the data (at float32 round-off), validates against the fitted parameters, records the fit, and `turbgen
export` takes the fitted profile and veer; the API's fit=True gives the same field."""

from __future__ import annotations

import hashlib
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import turbgen
from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.exporters import read_bts
from turbgen.exporters.options import ExportOptions, export_request

MAST = Path(__file__).resolve().parents[2] / "examples" / "mast-fit.json"
HUB = 88.5
# the data's own resolution (the mast was cut from a 3 m grid at dt 0.5 s): y nodes (k - 7.5) 3 m, z nodes hub +
# (k - 7) 3 m, so the sensors (y -1.5 m; 70.5, 82.5, 94.5, 106.5 m) sit on nodes iy 7 and iz 1, 5, 9, 13
GRID = ["--nt", "1024", "--dt", "0.5", "--ny", "16", "--nz", "15", "--dy", "3", "--planes", "0", "--evo", "frozen",
        "--hub-height", str(HUB)]
NODES = {70.5: 1, 82.5: 5, 94.5: 9, 106.5: 13}


@pytest.fixture(scope="module")
def replay(tmp_path_factory):
    out = tmp_path_factory.mktemp("replay") / "r.zarr"
    r = CliRunner().invoke(cli, ["mann", "--constrain", str(MAST), "--fit", *GRID, "--out", str(out)])
    assert r.exit_code == 0, r.output
    return out, r.output


def test_the_field_passes_through_the_data(replay):
    out, _ = replay
    ds = turbgen.open_store(out)
    fit, hub_u = ds.attrs["fit"], ds.attrs["U_m_s"]
    alpha = float(fit["export"]["profile"].split(":")[1])
    veer, turn = fit["export"]["veer_deg_per_m"], fit["turned_deg"]
    data = json.loads(MAST.read_text())
    field = {c: ds[c].values[:, 0, 7, :] for c in "uvw"}  # (t, z) at y = -1.5 m
    worst = bound = 0.0
    for s in data["sensors"]:
        h, iz = s["height_m"], NODES[s["height_m"]]
        # the data's direction at the hub and the fitted veer turned back, then the fitted power law removed
        a = math.radians(-veer * (h - HUB) - turn)
        u, v = np.array(s["u_m_s"]), np.array(s["v_m_s"])
        expected = {"u": u * math.cos(a) - v * math.sin(a) - hub_u * (h / HUB) ** alpha,
                    "v": u * math.sin(a) + v * math.cos(a), "w": np.array(s["w_m_s"])}
        for c in "uvw":
            worst = max(worst, float(np.abs(field[c][:, iz] - expected[c]).max()))
            bound = max(bound, float(np.abs(field[c][:, iz]).max()))
    # float32 round-off: the field is made by float32 FFTs over the synthesis box (nt x 2 ny x 2 nz, pad-yz 2), whose
    # error grows as eps32 log2(N) times the values' magnitude (Higham 2002, Sect. 24.1); the float64 solve adds a
    # relative 1e-13 (the record's relative residual) and the float32 storage eps32 / 2
    n_box = 1024 * (2 * 16) * (2 * 15)
    tol = np.finfo(np.float32).eps * math.log2(n_box) * bound
    assert worst <= tol, (worst, tol)
    assert ds.attrs["constraints"]["residual_max_m_s"] <= tol


def test_validate_passes_against_the_fitted_parameters(replay):
    out, _ = replay
    ds = turbgen.open_store(out)
    run = ds.attrs["fit"]["run"]
    assert {k: ds.attrs["parameters"][k] for k in ("ae", "length_scale_m", "gamma")} == \
        {k: run[k] for k in ("ae", "length_scale_m", "gamma")}
    report = turbgen.validate(out)
    assert report.passed, report.table()


def test_the_store_records_the_fit(replay):
    out, printed = replay
    fit = turbgen.open_store(out).attrs["fit"]
    assert fit["files"] == [{"path": str(MAST), "sha256": hashlib.sha256(MAST.read_bytes()).hexdigest()}]
    for k in ("ae", "length_scale_m", "gamma"):
        lo, hi = fit["fit"][k]["ci95"]
        assert lo < fit["run"][k] < hi and fit["run"][k] == float(f"{fit['fit'][k]['value']:.6g}")
    assert fit["fit"]["flags"] == [] and fit["fit"]["shear_exponent"]["value"] is not None
    assert set(fit["export"]) == {"profile", "veer_deg_per_m"}
    assert "fitted to mast-fit.json" in printed
    info = CliRunner().invoke(cli, ["info", str(out)]).output
    assert "fit  fitted to mast-fit.json: L" in info and "turbgen export uses --profile power:" in info


def test_export_takes_the_fitted_mean_wind_unless_given_one(replay, tmp_path):
    out, _ = replay
    fit = turbgen.open_store(out).attrs["fit"]["export"]
    wind = export_request(out, "bts", ExportOptions()).mean_wind
    assert (wind.profile, f"power:{wind.shear_exponent:.6g}", wind.veer_deg_per_m) == \
        ("power", fit["profile"], fit["veer_deg_per_m"])
    given = export_request(out, "bts", ExportOptions(profile="log:z0=0.1")).mean_wind
    assert (given.profile, given.veer_deg_per_m) == ("log", 0.0)
    r = CliRunner().invoke(cli, ["export", str(out), "--format", "bts", "--out", str(tmp_path / "r.bts")])
    assert r.exit_code == 0, r.output
    assert f"note: mean wind fitted to the store's data (its fit record): --profile {fit['profile']}" in r.output
    assert (tmp_path / "r_InflowWind_bts.dat").is_file()
    # the OpenFAST wind file gives the mast's total wind back: at the sensors' nodes the .bts (fluctuations plus the
    # fitted profile and veer) equals the data within its int16 quantisation step (range / 65534 per component)
    # in the field's frame (x along the data's mean wind direction at the hub, the record's turned_deg)
    bts, data = read_bts(tmp_path / "r.bts"), _turned(json.loads(MAST.read_text()), -turbgen.open_store(out).attrs[
        "fit"]["turned_deg"])
    for s in data["sensors"]:
        iy, iz = int(np.argmin(abs(bts["y"] - s["y_m"]))), int(np.argmin(abs(bts["z"] - s["height_m"])))
        for c in "uvw":
            step = (bts[c].max() - bts[c].min()) / 65534
            assert np.abs(bts[c][:, iy, iz] - np.array(s[f"{c}_m_s"])).max() <= step, (s["name"], c)


def _turned(data: dict, deg: float, positions: bool = True) -> dict:
    """A point-series mapping in a frame turned by ``-deg``: every sensor's (u, v) and (x, y) turned by ``deg``
    (counter-clockwise seen from above); only (u, v) without ``positions``."""
    c, n = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    for s in data["sensors"]:
        u, v = np.array(s["u_m_s"]), np.array(s["v_m_s"])
        s["u_m_s"], s["v_m_s"] = (u * c - v * n).tolist(), (u * n + v * c).tolist()
        if positions:
            s["x_m"], s["y_m"] = s["x_m"] * c - s["y_m"] * n, s["x_m"] * n + s["y_m"] * c
    return data


def test_a_mast_whose_axes_are_off_the_wind_fits_and_replays_as_the_aligned_one(replay, tmp_path):
    """The mast in a frame whose x is 25 deg off the wind (u, v and positions): the fit turns u, v into each
    sensor's mean wind (and says so), the replay turns the data and the positions into the field's x (its mean
    direction at the hub), so both are the aligned mast's: the fitted values to 1e-6, the sensors back at (0, -1.5) m,
    the field to float32 round-off (the bound of test_the_field_passes_through_the_data). Before, U came out 9 % low
    and ae 7 % high, unannounced, and the replay put the 5 m/s mean of v into the field."""
    turned = tmp_path / "turned.json"
    turned.write_text(json.dumps(_turned(json.loads(MAST.read_text()), 25.0)))
    a, b = turbgen.fit_mann(MAST), turbgen.fit_mann(turned)
    for k in ("ae", "length_scale_m", "gamma", "U_m_s"):
        va, vb = (getattr(f, k) if k == "U_m_s" else getattr(f, k).value for f in (a, b))
        assert vb == pytest.approx(va, rel=1e-6), k
    assert not any("mean wind blows" in n for n in a.notes)
    own = {s["name"]: math.degrees(math.atan2(np.mean(s["v_m_s"]), np.mean(s["u_m_s"])))
           for s in json.loads(MAST.read_text())["sensors"]}  # each sensor's own direction, a fraction of a degree
    most = max(own, key=lambda k: abs(own[k] + 25.0))
    assert f"the mean wind blows up to {own[most] + 25.0:+.1f} deg from x ({most};" in " ".join(b.notes), b.notes
    ds = turbgen.mann(constrain=[turned], fit=True, nt=1024, dt=0.5, ny=16, nz=15, dy=3, planes=[0], evo="frozen",
                      hub_height=HUB)
    stored = turbgen.open_store(replay[0])
    assert ds.attrs["fit"]["turned_deg"] == pytest.approx(stored.attrs["fit"]["turned_deg"] + 25.0, abs=1e-4)
    assert {tuple(xy) for xy in ds.attrs["fit"]["placed"].values()} == {(0.0, -1.5)}
    assert "placed" not in stored.attrs["fit"]  # the aligned mast's sensors moved by less than a centimetre
    bound = max(float(np.abs(stored[c].values).max()) for c in "uvw")
    tol = np.finfo(np.float32).eps * math.log2(1024 * (2 * 16) * (2 * 15)) * bound
    assert max(float(np.abs(ds[c].values - stored[c].values).max()) for c in "uvw") <= tol


def test_the_api_replays_the_same_field(replay):
    out, _ = replay
    ds = turbgen.mann(constrain=[MAST], fit=True, nt=1024, dt=0.5, ny=16, nz=15, dy=3, planes=[0], evo="frozen",
                      hub_height=HUB)
    stored = turbgen.open_store(out)
    assert all(np.array_equal(ds[c].values, stored[c].values) for c in "uvw")
    assert ds.attrs["fit"] == stored.attrs["fit"]


def test_a_run_file_s_fit_key_replays_the_same_field(replay, tmp_path):
    """``fit = true`` in a run file (schemas/mann-run.schema.json) is --fit: the same field and fit record."""
    run_file = tmp_path / "replay.json"
    run_file.write_text(json.dumps({"constrain": [str(MAST)], "fit": True, "hub_height_m": HUB, "evo_time_s": None,
                                    "grid": {"nt": 1024, "dt_s": 0.5, "x_m": [0], "ny": 16, "nz": 15, "dy_m": 3}}))
    out = tmp_path / "file.zarr"
    r = CliRunner().invoke(cli, ["mann", "--config", str(run_file), "--out", str(out)])
    assert r.exit_code == 0, r.output
    a, b = turbgen.open_store(out), turbgen.open_store(replay[0])
    assert all(np.array_equal(a[c].values, b[c].values) for c in "uvw")
    assert a.attrs["fit"]["run"] == b.attrs["fit"]["run"] and a.attrs["parameters"] == b.attrs["parameters"]


def test_plain_conditioning_on_data_off_the_wind_says_so(tmp_path):
    """Without --fit nothing is turned (the file's frame is the field's): conditioning on the mast turned by 25 deg
    notes the sensor furthest off and how many are beyond OFF_WIND_DEG; the aligned mast (a fraction of a degree)
    gets no note."""
    from turbgen.runs.constrain import OFF_WIND_DEG

    turned = tmp_path / "turned.json"
    turned.write_text(json.dumps(_turned(json.loads(MAST.read_text()), 25.0, positions=False)))
    grid = [*GRID, "--L", "24", "--U", "11.8"]
    s = json.loads(MAST.read_text())["sensors"][0]  # the furthest off: 70.5 m, a fraction of a degree of its own
    most = math.degrees(math.atan2(np.mean(s["v_m_s"]), np.mean(s["u_m_s"]))) + 25.0
    for data, note in ((MAST, None), (turned, f"turned.json:sonic 70.5 m: after the file's mean wind the data still "
                                              f"blow {most:+.1f} deg from the field's x (counter-clockwise from above; "
                                              f"4 sensor(s) beyond {OFF_WIND_DEG:g} deg)")):
        r = CliRunner().invoke(cli, ["mann", "--constrain", str(data), *grid, "--out", str(tmp_path / "f.zarr"),
                                     "--overwrite"])  # fmt: skip
        assert r.exit_code == 0, r.output
        assert ("note:" in r.output) == (note is not None) and (note is None or note in r.output), r.output
    with pytest.warns(UserWarning, match=f"^{re.escape(note)}"):  # the API's counterpart of the note
        turbgen.mann(constrain=[turned], L=24, U=11.8, nt=1024, dt=0.5, ny=16, nz=15, dy=3, planes=[0], evo="frozen",
                     hub_height=HUB)


def test_refusals(tmp_path):
    r = CliRunner().invoke(cli, ["mann", "--constrain", str(MAST), "--fit", "--L", "30", "--gamma", "3",
                                 "--out", str(tmp_path / "x.zarr")])
    assert r.exit_code == 2 and r.output.strip().splitlines()[-1] == (
        "Error: --L, --gamma with --fit (fit=True): the fit sets L, gamma and the energy level from the data; drop "
        "them, or drop --fit")
    r = CliRunner().invoke(cli, ["mann", "--fit", "--out", str(tmp_path / "x.zarr")])
    assert r.exit_code == 2 and r.output.strip().splitlines()[-1] == (
        "Error: fit (--fit) needs constrain (--constrain DATA): the data to fit and replay")
    assert not (tmp_path / "x.zarr").exists()
    with pytest.raises(ParameterError, match="^sigma_u with --fit"):
        turbgen.mann(constrain=[MAST], fit=True, sigma_u=1.0)
    with pytest.raises(ParameterError, match=r"^fit \(--fit\) needs constrain"):
        turbgen.mann(fit=True)
    with pytest.raises(ParameterError, match=r"^fit \(--fit\) needs constrain"):
        turbgen.mann(config={"fit": True})
    with pytest.raises(ParameterError, match="^--fit of 2 files: the sensor name.s. 'sonic 106.5 m', .* repeat; "):
        turbgen.mann(constrain=[MAST, MAST], fit=True)
    other = turbgen.point_series([0.0, 0.5, 1.0], [dict(name="cup", x_m=0, y_m=0, z_m=0, u_m_s=[9.0, 9.5, 9.2])],
                                 total_wind=True)
    with pytest.raises(ParameterError, match=r"^--fit of .*mast-fit.json and \(in memory\) measured: files fitted "
                                             r"together must share time_s, total_wind and mean_wind"):
        turbgen.mann(constrain=[MAST, other], fit=True)
    r = CliRunner().invoke(cli, ["mann", "--constrain", str(MAST), "--fit", "--factor1", "0.8",
                                 "--out", str(tmp_path / "x.zarr")])  # the fit's tables: factor1 = 1 only
    assert r.exit_code == 2 and r.output.strip().splitlines()[-1].startswith("Error: --fit with factor1 = 0.8: ")
    assert not (tmp_path / "x.zarr").exists()


def test_one_height_keeps_the_files_mean_wind_at_the_data_s_speed():
    """One sonic: no profile is fitted, so the file's mean wind (the default power law 0.2) stays and U is the hub
    speed at which it meets the sonic's mean u."""
    from turbgen.runs.replay import fitted_inputs
    from turbgen.spec.constraints import point_series_from_mapping

    data = json.loads(MAST.read_text())
    data["sensors"] = data["sensors"][:1]  # 70.5 m
    ps = point_series_from_mapping(data, "one.json")
    mapping, (placed,), record = fitted_inputs({"hub_height_m": HUB}, [ps])
    assert record["export"] == {} and placed.mean_wind == ps.mean_wind
    speed = np.hypot(np.mean(data["sensors"][0]["u_m_s"]), np.mean(data["sensors"][0]["v_m_s"]))  # u turned along it
    # rounded to 6 significant digits (FIT_DIGITS): within half a unit of the 6th, 5e-6 relative
    assert mapping["U_m_s"] == pytest.approx(speed * (HUB / 70.5) ** 0.2, rel=5e-6)
    assert "one height" in record["fit"]["shear_exponent"]["reason"]


def test_the_run_s_lifetime_is_the_fit_s_and_the_field_s(replay):
    """--fit with --lifetime mann fits Mann's (1994) lifetime and makes the field with it, recorded in the store;
    the default run (the fixture) fits and makes Guo's."""
    assert turbgen.open_store(replay[0]).attrs["fit"]["run"]["lifetime"] == "guo"
    ds = turbgen.mann(constrain=[MAST], fit=True, lifetime="mann", nt=1024, dt=0.5, ny=16, nz=15, dy=3, planes=[0],
                      evo="frozen", hub_height=HUB)
    fit = turbgen.fit_mann(MAST, lifetime="mann")
    record = ds.attrs["fit"]
    assert ds.attrs["parameters"]["lifetime"] == "mann" and record["run"]["lifetime"] == "mann"
    assert record["fit"]["lifetime"] == "mann"
    assert record["run"]["gamma"] == float(f"{fit.gamma.value:.6g}")
