"""Line-of-sight data as a plain CSV file (turbgen.virtual_lidar.los_csv): the same constraint as the dataset it was written
from, and one-line refusals of malformed files."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from test_lidar_constraints import GRID, LIDAR, loop  # noqa: F401  (the truth and its lidar record)
from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.virtual_lidar.dataset import read_dataset
from turbgen.virtual_lidar.los_csv import read_los_csv
from turbgen.runs.constrain import place
from turbgen.spec.mann import MannRun
from turbgen.store import open_store

HEADER = "# measured by the small lidar\n# lidar = small.json\n# U_m_s = 16\n# total_wind = true\n"


def _write_csv(path, v_los, time_s, header=HEADER, drop=()):
    rows = ["time_s,beam,gate,v_los_m_s"]
    for s in range(v_los.shape[0]):
        for b in range(v_los.shape[1]):
            for g in range(v_los.shape[2]):
                if (s, b, g) not in drop:
                    rows.append(f"{float(time_s[s, b])!r},{b},{g},{float(v_los[s, b, g])!r}")
    path.write_text(header + "\n".join(rows) + "\n")


@pytest.fixture(scope="module")
def record(loop):
    data = read_dataset(loop / "truth_lidar.zarr")
    _write_csv(loop / "los.csv", data.v_los, data.time_s)
    return loop, data


def test_csv_places_the_same_streams_and_data_as_the_dataset(record):
    d, data = record
    run = MannRun.from_mapping({"grid": {"nt": 256, "dt_s": 0.5, "x_m": [0.0, 20.0, 40.0], "ny": 8, "nz": 8,
                                         "dy_m": 5.0}})  # fmt: skip
    a, b = place(run, [data]), place(run, [read_los_csv(d / "los.csv")])
    np.testing.assert_array_equal(a.data, b.data)
    for name in ("plane", "term_stream", "term_component", "term_iy", "term_iz", "term_shift", "term_weight", "offset"):
        np.testing.assert_array_equal(getattr(a.streams, name), getattr(b.streams, name))


def test_field_constrained_by_the_csv_equals_the_dataset_one(record):
    d, _ = record
    r = CliRunner()
    for src, out in (("truth_lidar.zarr", "a.zarr"), ("los.csv", "b.zarr")):
        res = r.invoke(cli, ["mann", *GRID, "--seed", "2", "--constrain", str(d / src), "--out", str(d / out)],
                       prog_name="turbgen")  # fmt: skip
        assert res.exit_code == 0, res.output
    a, b = open_store(d / "a.zarr"), open_store(d / "b.zarr")
    for comp in "uvw":
        np.testing.assert_array_equal(a.read_plane(comp, 2), b.read_plane(comp, 2))


def test_missing_samples_are_gaps(record):
    d, data = record
    _write_csv(d / "gaps.csv", data.v_los, data.time_s)
    text = (d / "gaps.csv").read_text().splitlines()
    text[6] = ",".join(text[6].split(",")[:3]) + ","  # an empty v_los
    (d / "gaps.csv").write_text("\n".join(text) + "\n")
    got = read_los_csv(d / "gaps.csv").v_los
    assert np.isnan(got).sum() == 1 and np.isfinite(got).sum() == data.v_los.size - 1


@pytest.mark.parametrize("header, rows_drop, message", [
    ("# U_m_s = 16\n", (), "the header must give `# lidar"),
    ("# lidar = small.json\n", (), "the header must give `# U_m_s"),
    (HEADER + "# colour = red\n", (), "unknown header key 'colour'"),
    (HEADER.replace("true", "maybe"), (), "total_wind = 'maybe' must be true or false"),
    (HEADER.replace("U_m_s = 16", "U_m_s = -3"), (), "U_m_s = -3 must be > 0"),
    (HEADER, ((0, 1, 1),), "every beam and gate needs the same number of scans"),
])  # fmt: skip
def test_malformed_files_are_refused_in_one_line(record, tmp_path, header, rows_drop, message):
    d, data = record
    (tmp_path / "small.json").write_text(json.dumps(LIDAR))
    _write_csv(tmp_path / "bad.csv", data.v_los, data.time_s, header=header, drop=rows_drop)
    with pytest.raises(ParameterError, match=message.replace("(", r"\(")) as exc:
        read_los_csv(tmp_path / "bad.csv")
    assert "\n" not in str(exc.value)


def test_beam_index_outside_the_lidar_and_unequal_gate_times_are_refused(record, tmp_path):
    d, data = record
    (tmp_path / "small.json").write_text(json.dumps(LIDAR))
    _write_csv(tmp_path / "b.csv", data.v_los, data.time_s)
    lines = (tmp_path / "b.csv").read_text().splitlines()
    lines[5] = lines[5].replace(",0,0,", ",7,0,", 1)
    (tmp_path / "b.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(ParameterError, match=r"beam = 7 is not an index of the lidar's 2 beams \(0 .. 1\)"):
        read_los_csv(tmp_path / "b.csv")
    t = data.time_s.copy()
    _write_csv(tmp_path / "t.csv", data.v_los, t)
    lines = (tmp_path / "t.csv").read_text().splitlines()
    first = lines[5].split(",")  # scan 0, beam 0, gate 0: another time than gate 1
    lines[5] = ",".join([str(float(first[0]) + 0.25), *first[1:]])
    (tmp_path / "t.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(ParameterError, match="the gates of beam 0 are not measured at the same times"):
        read_los_csv(tmp_path / "t.csv")


def _netcdf(path, data, engine, attrs=None, drop=None):
    import xarray as xr

    s, b, g = np.meshgrid(*(np.arange(n) for n in data.v_los.shape), indexing="ij")
    columns = {"time_s": data.time_s[s, b].ravel(), "beam": b.ravel(), "gate": g.ravel(),
               "v_los_m_s": data.v_los.ravel()}  # fmt: skip
    if drop:
        columns.pop(drop)
    attrs = {"lidar": "small.json", "U_m_s": 16.0, "total_wind": 1} if attrs is None else attrs
    xr.Dataset({k: ("sample", v) for k, v in columns.items()}, attrs=attrs).to_netcdf(path, engine=engine)


@pytest.mark.parametrize("engine", ["h5netcdf", "scipy"])  # netCDF4/HDF5 and netCDF3 files
def test_netcdf_places_the_same_streams_and_data_as_the_dataset(record, engine):
    from turbgen.virtual_lidar.los_netcdf import read_los_netcdf
    from turbgen.runs.constrain import load_constraint

    d, data = record
    _netcdf(d / f"los_{engine}.nc", data, engine)
    got = load_constraint(d / f"los_{engine}.nc")
    assert got.v_los.shape == data.v_los.shape
    run = MannRun.from_mapping({"grid": {"nt": 256, "dt_s": 0.5, "x_m": [0.0, 20.0, 40.0], "ny": 8, "nz": 8,
                                         "dy_m": 5.0}})  # fmt: skip
    a, b = place(run, [data]), place(run, [read_los_netcdf(d / f"los_{engine}.nc")])
    np.testing.assert_array_equal(a.data, b.data)
    np.testing.assert_array_equal(a.streams.term_weight, b.streams.term_weight)


@pytest.mark.parametrize("attrs, drop, message", [
    ({"U_m_s": 16.0}, None, "the header must give `# lidar"),
    ({"lidar": "small.json", "U_m_s": 16.0, "colour": "red"}, None, "unknown global attribute 'colour'"),
    (None, "gate", r"the variables must be time_s, beam, gate, v_los_m_s \(missing gate\)"),
])  # fmt: skip
def test_malformed_netcdf_is_refused_in_one_line(record, tmp_path, attrs, drop, message):
    from turbgen.virtual_lidar.los_netcdf import read_los_netcdf

    d, data = record
    (tmp_path / "small.json").write_text(json.dumps(LIDAR))
    _netcdf(tmp_path / "bad.nc", data, "h5netcdf", attrs, drop)
    with pytest.raises(ParameterError, match=message) as exc:
        read_los_netcdf(tmp_path / "bad.nc")
    assert "\n" not in str(exc.value)
    (tmp_path / "text.nc").write_text("not netCDF\n")
    with pytest.raises(ParameterError, match="not readable as netCDF"):
        read_los_netcdf(tmp_path / "text.nc")


def test_the_documented_netcdf_example_runs(tmp_path, monkeypatch):
    """docs/constrained-fields.md's Python example writes a netCDF table that the reader's checks accept up to the
    lidar file (which the page leaves to the user): run as written."""
    import re
    from pathlib import Path

    from turbgen.virtual_lidar.los_netcdf import read_los_netcdf

    page = (Path(__file__).resolve().parents[2] / "docs" / "constrained-fields.md").read_text()
    block = re.search(r"The same table as a netCDF file.*?```python\n(.*?)```", page, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    exec(compile(block, "constrained-fields.md", "exec"), {})
    with pytest.raises(ParameterError, match="mylidar.toml"):  # the one thing missing: the user's lidar file
        read_los_netcdf(tmp_path / "los.nc")


def test_times_drifting_from_the_scan_period_are_refused(record):
    """Every scan period within 1e-6 dt of whole time steps, but the scans drift by 5e-7 dt each: the probe points'
    weights no longer repeat (sampling.repeats_every), refused in one line; the record as written places."""
    d, data = record
    run = MannRun.from_mapping({"grid": {"nt": 256, "dt_s": 0.5, "x_m": [0.0, 20.0, 40.0], "ny": 8, "nz": 8,
                                         "dy_m": 5.0}})  # fmt: skip
    drift = 5e-7 * 0.5 * np.arange(data.time_s.shape[0])[:, None]
    _write_csv(d / "drift.csv", data.v_los, data.time_s + drift)
    with pytest.raises(ParameterError, match="do not repeat every 4 time steps with the same weights"):
        place(run, [read_los_csv(d / "drift.csv")])
    place(run, [read_los_csv(d / "los.csv")])
