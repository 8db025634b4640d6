"""Point series as a CSV file (turbgen.spec.point_csv): the same PointSeries as the JSON file, so the same
conditioned field bit for bit and the same fit; every malformed file refused in one line naming the file."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import turbgen
from turbgen.errors import ParameterError
from turbgen.spec.constraints import load_point_series
from turbgen.validation.fit import load_fit_data

from test_run import SMALL, _mast

ROOT = Path(__file__).resolve().parents[2]


def as_csv(mapping: dict) -> str:
    """The CSV form of a point-series JSON mapping (the format of docs/constrained-fields.md)."""
    lines = ["# a mast as CSV (comment lines without an equals sign are ignored)", f"# name = {mapping['name']}",
             f"# total_wind = {str(mapping.get('total_wind', False)).lower()}"]
    for s in mapping["sensors"]:
        where = ", ".join(f"{k}={s[k]!r}" for k in ("x_m", "y_m", "z_m", "height_m", "path_m") if k in s)
        lines.append(f"# sensor {s['name']} = {where}")
    columns = [(s, c) for s in mapping["sensors"] for c in ("u_m_s", "v_m_s", "w_m_s") if c in s]
    lines.append(",".join(["time_s", *(f"{s['name']}:{c}" for s, c in columns)]))
    for i, t in enumerate(mapping["time_s"]):
        lines.append(",".join([repr(float(t)), *("" if s[c][i] is None else repr(float(s[c][i])) for s, c in columns)]))
    return "\n".join(lines) + "\n"


def _same(a, b):
    assert np.array_equal(a.time_s, b.time_s) and (a.name, a.total_wind, a.mean_wind) == (b.name, b.total_wind,
                                                                                           b.mean_wind)
    for sa, sb in zip(a.sensors, b.sensors, strict=True):
        assert (sa.name, sa.x_m, sa.y_m, sa.z_m, sa.height_m, sa.path_m) == (sb.name, sb.x_m, sb.y_m, sb.z_m,
                                                                                 sb.height_m, sb.path_m)
        assert sa.series.keys() == sb.series.keys()
        assert all(np.array_equal(sa.series[c], sb.series[c], equal_nan=True) for c in sa.series)


def test_the_example_csv_is_the_example_json():
    a, b = (load_point_series(ROOT / "examples" / f"mast-fit.{ext}") for ext in ("json", "csv"))
    _same(a, b)
    fa, fb = (load_fit_data(str(ROOT / "examples" / f"mast-fit.{ext}")) for ext in ("json", "csv"))
    assert all(np.array_equal(fa.series[c], fb.series[c], equal_nan=True) for c in fa.series)


def test_a_field_conditioned_on_the_csv_is_the_json_s(tmp_path):
    mast = _mast(np.arange(0.0, 30.0, 0.25))  # a gap in u, z_m and height_m, a sensor without u
    (tmp_path / "m.json").write_text(json.dumps(mast))
    (tmp_path / "m.csv").write_text(as_csv(mast))
    _same(load_point_series(tmp_path / "m.json"), load_point_series(tmp_path / "m.csv"))
    small = dict(nt=128, ny=4, nz=4, dy=10, planes=[0, 40], seed=3)
    assert SMALL[SMALL.index("--nt") + 1] == "128"
    a, b = (turbgen.mann(constrain=[tmp_path / f"m.{ext}"], **small) for ext in ("json", "csv"))
    for c in "uvw":
        np.testing.assert_array_equal(a[c].values, b[c].values)


GOOD = "# sensor s1 = x_m=0, y_m=0, z_m=0\ntime_s,s1:u_m_s\n0,1.0\n0.5,\n1.0,2.0\n"
BAD = {
    "unknown key": ("# speed = 12\n" + GOOD, "unknown header key 'speed'"),
    "undeclared sensor": (GOOD.replace("s1:u_m_s", "s2:u_m_s"), "column 's2:u_m_s' is not SENSOR:u_m_s"),
    "component": (GOOD.replace("s1:u_m_s", "s1:U"), "column 's1:U'"),
    "first column": (GOOD.replace("time_s,", "t,"), "the first column must be time_s (found t)"),
    "not a number": (GOOD.replace("0.5,", "0.5,abc"), "data row 3: 'abc' is not a number"),
    "row length": (GOOD.replace("1.0,2.0", "1.0,2.0,3.0"), "data row 4 has 3 values, 2 expected"),
    "sensor key": (GOOD.replace("z_m=0", "z=0"), "not z"),
    "no column": ("# sensor s2 = x_m=0, y_m=0, z_m=1\n" + GOOD, "sensor 's2' has no column"),
    "position": (GOOD.replace(", z_m=0", ""), "sensor 's1' needs x_m, y_m and one of z_m, height_m"),
    "times": (GOOD.replace("0.5,", "0,"), "time_s must be finite and strictly increasing"),
    "flag": ("# total_wind = yes\n" + GOOD, "total_wind = 'yes' must be true or false"),
}


@pytest.mark.parametrize("name", BAD)
def test_a_malformed_csv_is_one_line_naming_the_file(name, tmp_path):
    text, message = BAD[name]
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ParameterError, match=re.escape(message)) as err:
        load_point_series(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_an_empty_cell_is_a_missing_value(tmp_path):
    (tmp_path / "g.csv").write_text(GOOD)
    u = load_point_series(tmp_path / "g.csv").sensors[0].series["u"]
    assert np.isnan(u[1]) and u[0] == 1.0 and u[2] == 2.0
