"""MeanWind: each profile and veer against its formula at every height, and every refusal in one line."""

from __future__ import annotations

import math

import numpy as np
import pytest

from turbgen.errors import ParameterError
from turbgen.spec.mean_wind import MeanWind
from turbgen.spec.mean_wind_files import mean_wind_from_options, profile_fields

HUB = 90.0
HEIGHTS = np.array([12.0, 30.5, 61.0, 90.0, 119.0, 150.0])


def test_power_law_at_every_height():
    w = MeanWind(shear_exponent=0.14)
    for h, r in zip(HEIGHTS, w.speed_ratio(HEIGHTS, HUB)):
        assert r == pytest.approx(math.pow(h / HUB, 0.14), rel=1e-14)


def test_log_law_with_displacement_at_every_height():
    w = MeanWind(profile="log", roughness_m=0.3, displacement_m=5.0)
    for h, r in zip(HEIGHTS, w.speed_ratio(HEIGHTS, HUB)):
        assert r == pytest.approx(math.log((h - 5.0) / 0.3) / math.log((HUB - 5.0) / 0.3), rel=1e-14)
    assert w.speed_ratio([HUB], HUB)[0] == 1.0


def test_table_profile_and_table_veer_interpolate_linearly():
    w = MeanWind(profile="table", table_heights_m=(10.0, 90.0, 170.0), table_speeds_m_s=(6.0, 10.0, 12.0),
                 table_directions_deg=(-8.0, 2.0, 12.0))
    for h, r, d in zip(HEIGHTS, w.speed_ratio(HEIGHTS, HUB), w.veer_deg(HEIGHTS, HUB)):
        u = 6.0 + (h - 10.0) * 4.0 / 80.0 if h <= 90 else 10.0 + (h - 90.0) * 2.0 / 80.0
        direction = -8.0 + (h - 10.0) * 10.0 / 80.0  # one slope over both segments
        assert r == pytest.approx(u / 10.0, rel=1e-14)
        assert d == pytest.approx(direction - 2.0, abs=1e-12)  # relative to the hub's direction


def test_linear_veer_and_history():
    w = MeanWind(veer_deg_per_m=-0.1, history_times_s=(1.0, 3.0), history_speeds_m_s=(8.0, 12.0),
                 history_directions_deg=(0.0, 20.0))
    for h, d in zip(HEIGHTS, w.veer_deg(HEIGHTS, HUB)):
        assert d == pytest.approx(-0.1 * (h - HUB), abs=1e-12)
    speed, direction = w.hub_history([0.0, 1.0, 2.5, 3.0, 9.0], 10.0)
    np.testing.assert_allclose(speed, [8.0, 8.0, 11.0, 12.0, 12.0])  # end values held outside the times
    np.testing.assert_allclose(direction, [0.0, 0.0, 15.0, 20.0, 20.0])
    speed, direction = MeanWind().hub_history([0.0, 5.0], 10.0)
    assert speed.tolist() == [10.0, 10.0] and direction.tolist() == [0.0, 0.0]


def test_describe_default_is_the_earlier_exports_text():
    assert MeanWind().describe() == "power-law shear alpha = 0.2"
    assert MeanWind(profile="log", roughness_m=0.03, veer_deg_per_m=0.05).describe() == \
        "log law z0 = 0.03 m, d = 0 m; veer 0.05 deg/m; angles ccw from above"
    assert MeanWind(profile="log", roughness_m=0.03).to_attrs() == {"profile": "log", "roughness_m": 0.03,
                                                                    "displacement_m": 0.0}


@pytest.mark.parametrize("fields,msg", [
    ({"profile": "log", "roughness_m": 0.0}, "z0 (m) = 0.0 must be > 0"),
    ({"profile": "log", "roughness_m": -0.1}, "must be > 0"),
    ({"profile": "log"}, "needs a roughness length"),
    ({"profile": "table", "table_heights_m": (-5.0, 10.0), "table_speeds_m_s": (1.0, 2.0)}, "below the ground"),
    ({"profile": "table", "table_heights_m": (0.0, 10.0), "table_speeds_m_s": (1.0, 2.0)}, "below the ground"),
    ({"profile": "table", "table_heights_m": (10.0, 50.0, 30.0), "table_speeds_m_s": (1.0, 2.0, 3.0)},
     "increase strictly: 50 is followed by 30"),
    ({"profile": "table", "table_heights_m": (10.0, 50.0), "table_speeds_m_s": (1.0, 2.0),
      "table_directions_deg": (0.0, 4.0), "veer_deg_per_m": 0.1}, "not both"),
    ({"profile": "table", "table_heights_m": (10.0, 50.0), "table_speeds_m_s": (1.0,)}, "1 values for 2 rows"),
    ({"shear_exponent": 1.5}, "shear exponent = 1.5 is outside"),
    ({"veer_deg_per_m": 30.0}, "veer (deg/m) = 30 is outside"),
    ({"roughness_m": 0.1}, "belong to the log profile"),
    ({"history_times_s": (0.0, 2.0, 2.0), "history_speeds_m_s": (1.0, 2.0, 3.0)}, "increase strictly"),
    ({"history_times_s": (0.0, 2.0), "history_speeds_m_s": (1.0, -2.0)}, "= -2 is outside the allowed range [0, 150]"),
    # issue 37: a direction of 1e308 deg and a speed of 1e308 m/s were accepted
    ({"history_times_s": (0.0, 2.0), "history_speeds_m_s": (1.0, 2.0), "history_directions_deg": (0.0, 1e308)},
     "mean-history directions (deg) = 1e+308 is outside the allowed range [-360, 360]"),
    ({"history_times_s": (0.0, 2.0), "history_speeds_m_s": (1.0, 1e308)}, "speeds (m/s) = 1e+308 is outside"),
    ({"profile": "table", "table_heights_m": (10.0, 50.0), "table_speeds_m_s": (1.0, 2.0),
      "table_directions_deg": (0.0, -400.0)}, "profile table directions (deg) = -400 is outside"),
])
def test_bad_definitions_are_refused_in_one_line(fields, msg):
    with pytest.raises(ParameterError, match=None) as err:
        MeanWind(**fields)
    assert msg in str(err.value) and "\n" not in str(err.value)


def test_a_height_exactly_at_d_plus_z0_is_refused():
    # ln((h - d) / z0) = 0 there: the log law's speed is 0, not a profile; just above it is positive
    w = MeanWind(profile="log", roughness_m=0.5, displacement_m=10.0)  # d + z0 = 10.5 exactly in floating point
    with pytest.raises(ParameterError, match="height 10.5 m is at or below d \\+ z0 = 10.5 m"):
        w.speed_ratio([10.5, 90.0], HUB)
    assert 0.0 < w.speed_ratio([10.5 + 1e-9], HUB)[0] < 1e-8


def test_heights_the_profile_does_not_cover_are_refused():
    with pytest.raises(ParameterError, match="at or below d \\+ z0 = 10.5 m"):
        MeanWind(profile="log", roughness_m=0.5, displacement_m=10.0).speed_ratio([8.0, 90.0], HUB)
    w = MeanWind(profile="table", table_heights_m=(50.0, 150.0), table_speeds_m_s=(8.0, 11.0))
    with pytest.raises(ParameterError, match="grid height 12 m is outside the profile table's heights"):
        w.speed_ratio(HEIGHTS, HUB)
    with pytest.raises(ParameterError, match="outside the record \\[0, 5\\] s"):
        MeanWind(history_times_s=(-1.0, 2.0), history_speeds_m_s=(8.0, 9.0)).check_record(0.0, 5.0)


def test_options_text_and_files(tmp_path):
    assert profile_fields("power:0.11") == {"profile": "power", "shear_exponent": 0.11}
    assert profile_fields("log:z0=0.03,d=2") == {"profile": "log", "roughness_m": 0.03, "displacement_m": 2.0}
    table = tmp_path / "prof.csv"
    table.write_text("# z, U, dir\nz_m,U_m_s,dir_deg\n20, 8, -2\n90, 10, 0\n160 ,11, 3\n")
    w = mean_wind_from_options(f"table:{table}", None, None)
    assert w.table_heights_m == (20.0, 90.0, 160.0) and w.table_directions_deg == (-2.0, 0.0, 3.0)
    hist = tmp_path / "h.csv"
    hist.write_text("t,U\n0 10\n5 12\n")
    w = mean_wind_from_options(None, 0.1, hist)
    assert w.profile == "power" and w.veer_deg_per_m == 0.1 and w.history_speeds_m_s == (10.0, 12.0)
    assert mean_wind_from_options() is None
    for bad in ("cubic:3", "power:x", "log:d=3", "log:z0=0.1,k=2", "table:"):
        with pytest.raises(ParameterError):
            profile_fields(bad)
    hist.write_text("0 10\n1 x\n")
    with pytest.raises(ParameterError, match="line 2"):
        mean_wind_from_options(None, None, hist)
