"""Exports with a mean-wind profile, veer and hub-height history: read back (weio for .bts and HAWC2,
our readers for .wnd) they hold, at every grid height and time, the stored fluctuations plus the
formula's mean, rotated per height as TurbSim does; bad definitions exit 2 and write nothing."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from export_fixtures import make_store
from turbgen.cli import cli
from turbgen.exporters import ExportRequest, export_store, read_bts, read_hawc2, read_wnd
from turbgen.spec.mean_wind import MeanWind

HUB, U, NT, DT = 20.0, 10.0, 64, 0.1
HEIGHTS = HUB + (np.arange(7) - 3) * 3.0  # 11 .. 29 m


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return make_store(tmp_path_factory.mktemp("mw") / "s.zarr", hub_height_m=HUB, U_m_s=U)


def expected(data, speed_of_h, veer_of_h, hub_speed=None, hub_dir=None):
    """(u, v, w) (nt, ny, nz) from the formulas, computed point by point with math (independent of numpy paths)."""
    fl = {c: data[c][:, 0].astype(np.float64) for c in "uvw"}
    u, v = np.empty_like(fl["u"]), np.empty_like(fl["v"])
    for k in range(NT):
        for iz, h in enumerate(HEIGHTS):
            s = speed_of_h(h) * (1.0 if hub_speed is None else hub_speed[k] / U)
            a = math.radians(veer_of_h(h) + (0.0 if hub_dir is None else hub_dir[k]))
            uu, vv = s + fl["u"][k, :, iz], fl["v"][k, :, iz]
            u[k, :, iz] = uu * math.cos(a) - vv * math.sin(a)
            v[k, :, iz] = uu * math.sin(a) + vv * math.cos(a)
    return {"u": u, "v": v, "w": fl["w"]}


def bts_step(exp):
    return {c: (exp[c].max() - exp[c].min()) / 65535 for c in "uvw"}  # TurbSim's int16 step per component


def test_bts_log_law_and_veer_read_by_weio(store, tmp_path):
    weio_ts = pytest.importorskip("weio.turbsim_file")
    path, data = store
    wind = MeanWind(profile="log", roughness_m=0.05, displacement_m=2.0, veer_deg_per_m=0.8)
    r = export_store(path, "bts", tmp_path / "f.bts", ExportRequest(mean_wind=wind))
    exp = expected(data, lambda h: U * math.log((h - 2.0) / 0.05) / math.log((HUB - 2.0) / 0.05),
                   lambda h: 0.8 * (h - HUB))
    ts = weio_ts.TurbSimFile(str(tmp_path / "f.bts"))
    step = bts_step(exp)
    for k, c in enumerate("uvw"):
        assert np.abs(ts["u"][k] - exp[c]).max() <= 0.5 * step[c] * (1 + 1e-4) + 1e-6
    assert "log law z0 = 0.05 m, d = 2 m; veer 0.8 deg/m" in read_bts(tmp_path / "f.bts")["description"]
    assert any("mean wind: log law" in n for n in r.notes) and any("counter-clockwise" in n for n in r.notes)


def test_bts_non_periodic_history_uses_arrival_times_and_states_the_shift(store, tmp_path):
    path, data = store
    shift = 0.5 * 4 * 2.0 / U  # (ny - 1) dy / 2 / U = 0.4 s
    wind = MeanWind(shear_exponent=0.1, history_times_s=(1.0, 4.0), history_speeds_m_s=(9.0, 13.0),
                    history_directions_deg=(0.0, 30.0))
    r = export_store(path, "bts", tmp_path / "n.bts", ExportRequest(periodic=False, mean_wind=wind))
    t = DT * np.arange(NT) - shift  # slice k reaches the turbine at k dt - InitX/U
    hub_speed = np.interp(t, [1.0, 4.0], [9.0, 13.0])
    hub_dir = np.interp(t, [1.0, 4.0], [0.0, 30.0])
    exp = expected(data, lambda h: U * (h / HUB) ** 0.1, lambda h: 0.0, hub_speed, hub_dir)
    b = read_bts(tmp_path / "n.bts")
    step = bts_step(exp)
    for c in "uvw":
        assert np.abs(b[c] - exp[c]).max() <= 0.5 * step[c] * (1 + 1e-4) + 1e-6
    assert b["id"] == 7 and b["U_m_s"] == U  # the advection speed stays the store's U
    assert b["description"].startswith("NOT PERIODIC: starts 0.4 s upstream")
    assert any("starts the file 0.4 s upstream" in n for n in r.notes)
    assert any("Taylor's shift uses the hub mean" in n for n in r.notes)


def test_bts_tower_points_carry_the_profile_and_veer(store, tmp_path):
    path, data = store
    wind = MeanWind(veer_deg_per_m=-1.0)
    export_store(path, "bts", tmp_path / "t.bts", ExportRequest(tower=True, mean_wind=wind))
    b = read_bts(tmp_path / "t.bts")
    fu, fv = data["u"][:, 0, 2, 0].astype(float), data["v"][:, 0, 2, 0].astype(float)
    for j, h in enumerate(b["tower_z"]):
        a = math.radians(-1.0 * (h - HUB))
        uu = U * (h / HUB) ** 0.2 + fu
        exp_u, exp_v = uu * math.cos(a) - fv * math.sin(a), uu * math.sin(a) + fv * math.cos(a)
        assert np.abs(b["tower_u"][:, j] - exp_u).max() < 5e-4  # int16 step of a ~14 m/s range
        assert np.abs(b["tower_v"][:, j] - exp_v).max() < 5e-4


def test_hawc2_table_profile_with_veer_read_by_weio(store, tmp_path):
    weio_mb = pytest.importorskip("weio.mannbox_file")
    path, data = store
    wind = MeanWind(profile="table", table_heights_m=(5.0, 20.0, 40.0), table_speeds_m_s=(4.0, 8.0, 9.0),
                    table_directions_deg=(10.0, 0.0, -20.0))
    export_store(path, "hawc2", tmp_path / "box", ExportRequest(mean_wind=wind))

    def table(h, values):
        return values[0] + (h - 5.0) * (values[1] - values[0]) / 15.0 if h <= 20 else \
            values[1] + (h - 20.0) * (values[2] - values[1]) / 20.0

    exp = expected(data, lambda h: U * table(h, (4.0, 8.0, 9.0)) / 8.0, lambda h: table(h, (10.0, 0.0, -20.0)))
    own = read_hawc2(tmp_path / "box", (NT, 5, 7), U)
    for c in "uvw":
        mb = weio_mb.MannBoxFile(str(tmp_path / f"box_{c}.bin"), N=(NT, 5, 7), dy=2.0, dz=3.0)
        field = mb["field"].astype(np.float64) + (U if c == "u" else 0.0)
        assert np.abs(field - exp[c]).max() <= 4e-6  # float32 rounding of values up to ~15 m/s
        assert np.abs(own[c] - exp[c]).max() <= 4e-6


def test_wnd_power_veer_history(store, tmp_path):
    path, data = store
    wind = MeanWind(veer_deg_per_m=0.5, history_times_s=(0.0, 6.3), history_speeds_m_s=(8.0, 12.0))
    export_store(path, "wnd", tmp_path / "r", ExportRequest(mean_wind=wind))
    w = read_wnd(tmp_path / "r.wnd")
    hub_speed = np.interp(DT * np.arange(NT), [0.0, 6.3], [8.0, 12.0])
    exp = expected(data, lambda h: U * (h / HUB) ** 0.2, lambda h: 0.5 * (h - HUB), hub_speed)
    h = w["header"]
    for k, c in enumerate("uvw"):
        tol = 0.5 * h.U_m_s * 1e-5 * h.ti_percent[k] * (1 + 1e-5) + 1e-5  # half a Bladed int16 step
        assert np.abs(w[c] - exp[c]).max() <= tol
    assert "veer 0.5 deg/m; hub history (2 points)" in (tmp_path / "r.sum").read_text().splitlines()[0]


def run(*args):
    return CliRunner().invoke(cli, ["export", *map(str, args)])


def test_cli_profile_veer_history(store, tmp_path):
    path, _ = store
    hist = tmp_path / "hist.csv"
    hist.write_text("t_s,U_m_s,dir_deg\n0,10,0\n6,12,10\n")
    out = tmp_path / "out"
    out.mkdir()
    res = run(path, "--format", "bts", "--out", out / "f.bts", "--profile", "log:z0=0.03", "--veer", "-0.1",
              "--mean-history", hist)
    assert res.exit_code == 0, res.output
    assert "log law z0 = 0.03 m, d = 0 m; veer -0.1 deg/m; hub history hist.csv (2 points)" in res.output
    res = run(path, "--format", "bts", "--out", out / "g.bts", "--shear-exponent", "0.1", "--veer", "0.2")
    assert res.exit_code == 0 and "power-law shear alpha = 0.1; veer 0.2 deg/m" in res.output


@pytest.mark.parametrize("args,table,msg", [
    (["--profile", "table:TABLE"], "-5 8\n20 10\n40 11\n", "below the ground"),
    (["--profile", "table:TABLE"], "5 8 0\n30 10 2\n20 11 4\n", "increase strictly: 30 is followed by 20"),
    (["--profile", "log:z0=0"], None, "z0 (m) = 0.0 must be > 0"),
    (["--profile", "log:z0=-0.2"], None, "must be > 0"),
    (["--profile", "log:z0=0.1,d=12"], None, "at or below d + z0"),
    (["--mean-history", "TABLE"], "0 10\n9 12\n", "outside the record [0, 6.3] s"),
    (["--mean-history", "TABLE"], "-1 10\n3 12\n", "outside the record"),
    (["--veer", "40"], None, "veer (deg/m) = 40 is outside"),
    (["--profile", "power:0.1", "--shear-exponent", "0.2"], None, "give one"),
    (["--profile", "spline:3"], None, "is not one of power:ALPHA"),
])
def test_bad_mean_wind_exit_2_nothing_written(store, tmp_path, args, table, msg):
    path, _ = store
    src = tmp_path / "src"
    src.mkdir()
    if table is not None:
        (src / "t.csv").write_text(table)
    out = tmp_path / "out"
    out.mkdir()
    res = run(path, "--format", "bts", "--out", out / "f.bts", *[a.replace("TABLE", str(src / "t.csv")) for a in args])
    assert res.exit_code == 2, res.output
    assert msg in res.output and len(res.output.strip().splitlines()) == 1 and "Traceback" not in res.output
    assert not list(out.iterdir())


def test_mean_wind_refused_by_formats_without_a_mean(store, tmp_path):
    path, _ = store
    res = run(path, "--format", "hdf5", "--out", tmp_path / "f.h5", "--veer", "0.1")
    assert res.exit_code == 2 and "no mean profile is added" in res.output
    assert not list(tmp_path.iterdir())


def test_sum_title_cannot_fake_a_key(store, tmp_path):
    from turbgen.exporters import read_sum

    path, _ = store
    wind = MeanWind(profile="table", table_heights_m=(5.0, 40.0), table_speeds_m_s=(8.0, 11.0),
                    table_label="PERIODIC hub height 99 UBar.csv")
    export_store(path, "wnd", tmp_path / "r", ExportRequest(mean_wind=wind, periodic=False))
    s = read_sum(tmp_path / "r.sum")
    assert s["periodic"] is False and s["hub_height_m"] == HUB and s["U_m_s"] == pytest.approx(U)
