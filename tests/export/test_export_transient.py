"""IEC transients superimposed on a turbulent field: at every grid point and slice the export holds the
fluctuations plus the power-law mean plus the standard's event at the time the slice reaches the turbine
(formulas written here independently), rotated for direction changes; refusals in one line."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from export_fixtures import make_store
from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.exporters import ExportRequest, export_store, read_bts, read_hawc2
from turbgen.spec.iec_transient import IecTransient
from turbgen.spec.mean_wind import MeanWind

HUB, U, NT, DT, D = 20.0, 10.0, 256, 0.1, 24.0
HEIGHTS = HUB + (np.arange(7) - 3) * 3.0
Y = (np.arange(5) - 2) * 2.0
SIGMA1 = 0.14 * (0.75 * U + 5.6)
LAMBDA1 = 0.7 * HUB


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return make_store(tmp_path_factory.mktemp("tr") / "s.zarr", hub_height_m=HUB, U_m_s=U, nt=NT, x_m=(0.0,))


def event(kind, tau, sign):
    """(gust, shear across D, direction counter-clockwise) of the standard at event time tau, class IIB."""
    if kind == "ECD":
        t = min(max(tau, 0.0), 10.0)
        rise = 0.5 * (1 - math.cos(math.pi * t / 10.0))
        return 15.0 * rise, 0.0, -sign * (720.0 / U) * rise  # InflowWind's clockwise angle, flipped
    t = min(max(tau, 0.0), 12.0)
    return 0.0, sign * (2.5 + 0.2 * 6.4 * SIGMA1 * (D / LAMBDA1) ** 0.25) * (1 - math.cos(2 * math.pi * t / 12.0)), 0.0


def expected(data, kind, start, sign, shift=0.0):
    fl = {c: data[c][:, 0].astype(np.float64) for c in "uvw"}
    u, v = np.empty_like(fl["u"]), np.empty_like(fl["v"])
    for k in range(NT):
        g, s, turn = event(kind, k * DT - shift - start, sign)
        a = math.radians(turn)
        for iz, h in enumerate(HEIGHTS):
            for iy, y in enumerate(Y):
                x = {"ECD": 0.0, "EWS-V": (h - HUB) / D, "EWS-H": y / D}[kind]
                uu = U * (h / HUB) ** 0.2 + g + s * x + fl["u"][k, iy, iz]
                vv = fl["v"][k, iy, iz]
                u[k, iy, iz] = uu * math.cos(a) - vv * math.sin(a)
                v[k, iy, iz] = uu * math.sin(a) + vv * math.cos(a)
    return {"u": u, "v": v, "w": fl["w"]}


def wind(kind, start=5.0, sign=1):
    return MeanWind(transient=IecTransient(kind, "IIB", U, HUB, D, start_s=start, duration_s=25.5, sign=sign))


def test_ecd_on_a_non_periodic_bts(store, tmp_path):
    path, data = store
    r = export_store(path, "bts", tmp_path / "e.bts", ExportRequest(periodic=False, mean_wind=wind("ECD", sign=-1)))
    b = read_bts(tmp_path / "e.bts")
    exp = expected(data, "ECD", 5.0, -1, shift=0.4)  # slice k reaches the turbine at k dt - 0.4 s
    for c in "uvw":
        step = (exp[c].max() - exp[c].min()) / 65535
        assert np.abs(b[c] - exp[c]).max() <= 0.5 * step * (1 + 1e-4) + 1e-6
    assert b["U_m_s"] == U  # Taylor's shift keeps the hub mean
    assert any("X/U s earlier" in n for n in r.notes) and "IEC ECD IIB" in b["description"]


@pytest.mark.parametrize("kind", ["EWS-V", "EWS-H"])
def test_ews_on_hawc2(store, tmp_path, kind):
    path, data = store
    export_store(path, "hawc2", tmp_path / "b", ExportRequest(mean_wind=wind(kind, start=3.0)))
    got = read_hawc2(tmp_path / "b", (NT, 5, 7), U)
    exp = expected(data, kind, 3.0, 1)
    for c in "uvw":
        assert np.abs(got[c] - exp[c]).max() <= 4e-6  # float32 rounding of values up to ~20 m/s


def test_refusals(store, tmp_path):
    path, _ = store
    other = MeanWind(transient=IecTransient("EOG", "IIB", 12.0, HUB, D, start_s=1.0, duration_s=25.5))
    with pytest.raises(ParameterError, match="superimpose it at the field's own hub speed"):
        export_store(path, "bts", tmp_path / "x.bts", ExportRequest(mean_wind=other))
    with pytest.raises(ParameterError, match="give one"):
        MeanWind(history_times_s=(0.0, 1.0), history_speeds_m_s=(9.0, 10.0),
                 transient=IecTransient("EOG", "IIB", U, HUB, D, start_s=1.0, duration_s=25.5))
    with pytest.raises(ParameterError, match="outside the record \\[0, 25.1\\] s"):  # non-periodic: 0.4 s less
        export_store(path, "bts", tmp_path / "x.bts", ExportRequest(periodic=False, mean_wind=wind("EOG", 14.8)))
    assert not list(tmp_path.iterdir())


def test_cli(store, tmp_path):
    path, _ = store
    base = ["export", str(path), "--format", "bts", "--out", str(tmp_path / "a.bts")]
    res = CliRunner().invoke(cli, [*base, "--transient", "eog", "--iec-class", "IIB", "--rotor-diameter", "24",
                                   "--transient-start", "2"])
    assert res.exit_code == 0, res.output
    assert "IEC 61400-1 Ed. 4 EOG, class IIB, V_hub 10 m/s" in res.output and "superimposed" in res.output
    for args, msg in [(["--transient", "eog"], "needs --iec-class and --rotor-diameter"),
                      (["--iec-class", "IIB"], "belong to --transient"),
                      (["--transient", "edc", "--iec-class", "IIB", "--rotor-diameter", "24", "--transient-start",
                        "20"], "outside the record of 25.5 s")]:
        res = CliRunner().invoke(cli, [*base[:-1], str(tmp_path / "b.bts"), *args])
        assert res.exit_code == 2 and msg in res.output and len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "b.bts").exists()
