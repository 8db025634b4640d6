"""``turbgen.point_series``: measured series made in memory are the PointSeries their constraint file gives, so the
same conditioned field bit for bit and the same fit; bad input is one line naming the value."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import turbgen
from turbgen.errors import ParameterError
from turbgen.spec.constraints import load_point_series

from test_point_csv import _same
from test_run import _mast

ROOT = Path(__file__).resolve().parents[2]


def in_memory(mapping: dict):
    """``turbgen.point_series`` of a constraint file's mapping, its series as numpy arrays (NaN missing)."""
    sensors = [{k: np.array([np.nan if x is None else x for x in v]) if k.endswith("_m_s") else v
                for k, v in s.items()} for s in mapping["sensors"]]
    keys = {k: mapping[k] for k in ("total_wind", "noise_m_s", "mean_wind", "name") if k in mapping}
    return turbgen.point_series(np.asarray(mapping["time_s"]), sensors, **keys)


def test_in_memory_series_condition_a_field_as_their_file(tmp_path):
    mast = _mast(np.arange(0.0, 30.0, 0.25))  # a gap in u, z_m and height_m, a sensor without u
    (tmp_path / "m.json").write_text(json.dumps(mast))
    series = in_memory(mast)
    _same(series, load_point_series(tmp_path / "m.json"))
    small = dict(nt=128, ny=4, nz=4, dy=10, planes=[0, 40], seed=3)
    a, b = (turbgen.mann(constrain=[c], **small) for c in (tmp_path / "m.json", series))
    for c in "uvw":
        np.testing.assert_array_equal(a[c].values, b[c].values)


def test_in_memory_example_mast_fits_as_its_file():
    mapping = json.loads((ROOT / "examples" / "mast-fit.json").read_text())
    a, b = turbgen.fit_mann(ROOT / "examples" / "mast-fit.json"), turbgen.fit_mann(in_memory(mapping))
    assert a.ok and b.ok
    da, db = a.to_dict(), b.to_dict()
    assert (da.pop("source"), db.pop("source")) == (str(ROOT / "examples" / "mast-fit.json"),
                                                  f"(in memory) {mapping['name']}")
    assert da == db
    # the example's sonics are points cut from a 3 m box: they lack its missing wavenumbers, which the continuous
    # model holds (benchmarks/fit_wetb.md, "sonic1"), and the fit says so rather than trusting its intervals
    assert any(n.startswith("the model misfits these data: chi2/dof = 2.25 over 49 dof (tail probability 1.4e-06")
               for n in a.notes), a.notes


SENSOR = {"name": "s", "x_m": 0.0, "y_m": 0.0, "z_m": 0.0, "u_m_s": [1.0, 2.0, 3.0]}
BAD = {
    "sensor not a dict": ([0, 1, 2], ["s"], "sensors[0] must be a dict of a sensor's keys, not str"),
    "2-D series": ([0, 1, 2], [{**SENSOR, "u_m_s": np.ones((3, 2))}], "sensors[0] u_m_s must be one-dimensional"),
    "text values": ([0, 1, 2], [{**SENSOR, "u_m_s": ["a", "b", "c"]}], "sensors[0] u_m_s must be numbers"),
    "no position": ([0, 1, 2], [{k: v for k, v in SENSOR.items() if k != "x_m"}], "'x_m' is a required property"),
    "length": ([0, 1, 2, 3], [SENSOR], "s u_m_s has 3 values for 4 times"),
    "times": ([0, 2, 1], [SENSOR], "time_s must be finite and strictly increasing"),
    "all missing": ([0, 1, 2], [{**SENSOR, "u_m_s": [np.nan] * 3}], "s u_m_s has no value (all missing)"),
    "huge value": ([0, 1, 2], [{**SENSOR, "u_m_s": [1.0, 1e30, 2.0]}], "s u_m_s"),
}


@pytest.mark.parametrize("name", BAD)
def test_bad_in_memory_series_is_one_line(name):
    t, sensors, message = BAD[name]
    with pytest.raises(ParameterError, match=re.escape(message)) as err:
        turbgen.point_series(t, sensors, name="site")
    assert "\n" not in str(err.value) and "point_series" in str(err.value)


def test_a_point_series_shows_what_it_holds():
    t = np.arange(0.0, 600.0, 0.05)
    mast = turbgen.point_series(t, [dict(name=f"s{k}", x_m=0, y_m=-1.5, height_m=70.5 + 12 * k, u_m_s=10 + np.sin(t),
                                         w_m_s=0 * t) for k in range(40)], total_wind=True, name="mast")
    text = repr(mast)
    assert text.startswith("PointSeries 'mast': 12000 samples, 0 to 599.95 s, total wind; s0 (x 0 m, y -1.5 m, "
                           "height 70.5 m: u w); s1 (") and len(text) < 60 * 40  # not the 480,000 values


def test_in_memory_series_are_checked_without_listing_every_value(monkeypatch):
    """The schema sees the series' first values (the rest are floats by construction); its sample limit is kept."""
    import turbgen.spec.constraints as constraints

    schema = constraints.load_schema("constraints")
    small = {**schema, "properties": {**schema["properties"], "time_s": {**schema["properties"]["time_s"],
                                                                           "maxItems": 3}}}
    monkeypatch.setattr(constraints, "load_schema", lambda name: small)
    with pytest.raises(ParameterError, match=r"^point_series 'site': time_s holds 4 samples \(at most 3\)$"):
        turbgen.point_series([0, 1, 2, 3], [{**SENSOR, "u_m_s": [1.0, 2.0, 3.0, 4.0]}], name="site")


def test_a_long_file_s_values_are_checked_as_the_schema_would_name_them(tmp_path, monkeypatch):
    """A 20 Hz file's lists reach the schema cut to their first values when they hold only numbers (null in a
    series); any other value deep in a list, and a list over the sample limit, get the full check's message."""
    import turbgen.spec.config as config
    import turbgen.spec.constraints as constraints

    n = 12_000  # 10 min at 20 Hz
    t = (np.arange(n) * 0.05).tolist()
    u = np.sin(np.arange(n) * 0.01).tolist()
    u[5_432] = None  # missing
    data = {"kind": "point-series", "total_wind": False, "time_s": t, "sensors": [{**SENSOR, "u_m_s": u}]}
    path = tmp_path / "long.json"
    path.write_text(json.dumps(data))
    ps = load_point_series(path)
    assert ps.time_s.size == n and np.isnan(ps.sensors[0].series["u"][5_432])
    np.testing.assert_array_equal(np.delete(ps.sensors[0].series["u"], 5_432), np.delete(np.array(u), 5_432).astype(float))
    for key, value, message in (("u_m_s", "3.1", "sensors/0/u_m_s/10000: '3.1' is not of type 'number', 'null'"),
                                ("u_m_s", True, "sensors/0/u_m_s/10000: True is not of type 'number', 'null'"),
                                ("time_s", None, "time_s/10000: None is not of type 'number'")):
        bad = json.loads(json.dumps(data))
        (bad["sensors"][0] if key == "u_m_s" else bad)[key][10_000] = value
        path.write_text(json.dumps(bad))
        with pytest.raises(ParameterError, match=f"^constraint file {re.escape(str(path))}: {re.escape(message)}$"):
            load_point_series(path)
    schema = constraints.load_schema("constraints")
    small = {**schema, "properties": {**schema["properties"], "time_s": {**schema["properties"]["time_s"],
                                                                           "maxItems": n - 1}}}
    for module in (constraints, config):  # the view's limit and the check's schema
        monkeypatch.setattr(module, "load_schema", lambda name: small)
    path.write_text(json.dumps(data))
    with pytest.raises(ParameterError, match=r"time_s: a list of 12000 items is too long \(at most 11999\)$"):
        load_point_series(path)
