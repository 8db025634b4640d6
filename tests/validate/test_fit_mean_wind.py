"""The mean wind of total-wind sensor data (turbgen.validation.fit.mean_wind): a known power law and veer laid on a
turbgen field's fluctuations at four heights are recovered within their 95 % intervals; one height, fluctuation data
and a store say why nothing is identified; `turbgen fit mann --json` carries the four keys."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import turbgen
from turbgen.cli import cli
from turbgen.spec.constraints import point_series_from_mapping
from turbgen.spec.mean_wind import MeanWind
from turbgen.validation.fit.mean_wind import fit_mean_wind

ALPHA, VEER, U, HUB, DT = 0.14, -0.1, 12.0, 88.5, 0.5
HEIGHTS = (70.5, 82.5, 94.5, 106.5)  # grid nodes of the field below (nz 9, dz 6 m about the hub)


@pytest.fixture(scope="module")
def field():
    return turbgen.mann(L=20, gamma=3.2, ae=0.08, evo="frozen", U=U, nt=1024, dt=DT, ny=4, nz=9, dy=3, dz=6,
                        planes=[0], hub_height=HUB, seed=3)


def mast(field, heights=HEIGHTS, total=True) -> dict:
    """Sensors at y = -1.5 m (node 1) and ``heights``: the field's u, v, w plus the known mean wind (total wind)."""
    wind = MeanWind(shear_exponent=ALPHA, veer_deg_per_m=VEER)
    t = np.arange(field.sizes["t"]) * DT
    sensors = []
    for h in heights:
        iz = round((h - HUB) / 6 + 4)
        u, v, w = (field[c].values[:, 0, 1, iz].astype(float) for c in "uvw")
        if total:
            u, v = wind.full_uv(u, v, t, -1.5, h, U, HUB)
        sensors.append({"name": f"{h} m", "x_m": 0.0, "y_m": -1.5, "height_m": h, "u_m_s": list(u),
                        "v_m_s": list(v), "w_m_s": list(w)})
    return {"kind": "point-series", "time_s": list(t), "total_wind": total, "sensors": sensors}


def test_known_profile_and_veer_are_recovered_within_their_intervals(field):
    m = fit_mean_wind(point_series_from_mapping(mast(field), "mast.json"), HUB)
    for est, truth in ((m.shear_exponent, ALPHA), (m.veer_deg_per_m, VEER)):
        assert est.ci95[0] <= truth <= est.ci95[1], (est, truth)
        assert est.ci95[0] * est.ci95[1] > 0  # informative: no shear / no veer (0) is outside the interval
    assert m.z0_m.value > 0 and m.z0_m.ci95[0] < m.z0_m.value < m.z0_m.ci95[1]
    # the hub speed of the fitted power law: U within the spread the turbulence leaves on the means
    assert m.U_hub_m_s == pytest.approx(U, rel=0.02)
    # TI of the sensor nearest the hub (82.5 and 94.5 m are 6 m away: the first), sigma of the along-wind series / U
    ps = point_series_from_mapping(mast(field), "mast.json")
    u, v = ps.sensors[1].series["u"], ps.sensors[1].series["v"]
    a = math.atan2(v.mean(), u.mean())
    along = u * math.cos(a) + v * math.sin(a)
    assert m.ti_sensor == "82.5 m at 82.5 m"
    assert m.turbulence_intensity.value == pytest.approx(along.std() / along.mean(), rel=1e-12)
    assert m.export_options() == {"profile": f"power:{m.shear_exponent.value:.6g}",
                                  "veer_deg_per_m": float(f"{m.veer_deg_per_m.value:.6g}")}


def test_what_is_not_identified_is_said(field):
    one = fit_mean_wind(point_series_from_mapping(mast(field, heights=(94.5,)), "m.json"), HUB)
    assert one.shear_exponent.value is None and "one height" in one.shear_exponent.reason
    assert one.veer_deg_per_m.value is None and one.turbulence_intensity.value > 0
    fluct = fit_mean_wind(point_series_from_mapping(mast(field, total=False), "m.json"), HUB)
    assert all(getattr(fluct, n).value is None and "fluctuations" in getattr(fluct, n).reason
               for n in ("shear_exponent", "z0_m", "veer_deg_per_m", "turbulence_intensity"))
    assert fit_mean_wind(None).to_dict()["shear_exponent"] == {"value": None, "ci95": None,
                                                               "reason": fluct.shear_exponent.reason}


def test_fit_mann_json_carries_the_mean_wind(field, tmp_path):
    (tmp_path / "mast.json").write_text(json.dumps(mast(field)))
    r = CliRunner().invoke(cli, ["fit", "mann", str(tmp_path / "mast.json"), "--json"])
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    for key in ("shear_exponent", "z0_m", "veer_deg_per_m", "turbulence_intensity"):
        assert set(d[key]) >= {"value", "ci95", "reason"} and d[key]["value"] is not None
    assert d["shear_exponent"]["ci95"][0] <= ALPHA <= d["shear_exponent"]["ci95"][1]
    text = CliRunner().invoke(cli, ["fit", "mann", str(tmp_path / "mast.json")]).output
    assert "mean wind:" in text and "veer_deg_per_m" in text
