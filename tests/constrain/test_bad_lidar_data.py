"""Lidar constraint data that used to end in a traceback (issue 37 §2): a dataset whose v_los are all NaN (an empty
reduction) and a dataset with a chunk that does not decompress (a Zstd error) are refused in one line, exit 2,
nothing written."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli

LIDAR = {"name": "small", "kind": "pulsed", "mount": "nacelle", "ranges_m": [20, 40], "beam_rate_hz": 1.0,
         "rotor_radius_m": 10, "azimuth_deg": [10, -10], "elevation_deg": [5, -5], "fwhm_m": 4}  # fmt: skip
GRID = ["--nt", "256", "--ny", "8", "--nz", "8", "--dy", "5", "--planes", "0,20,40", "--threads", "1"]


@pytest.fixture(scope="module")
def datasets(tmp_path_factory):
    """A lidar dataset measured on a small field, a copy with every v_los NaN and a copy with a garbage chunk."""
    import zarr

    d = tmp_path_factory.mktemp("bad_lidar")
    (d / "small.json").write_text(json.dumps(LIDAR))
    for args in (["mann", *GRID, "--seed", "1", "--out", str(d / "truth.zarr")],
                 ["lidar", "run", str(d / "truth.zarr"), "--lidar", str(d / "small.json"), "--rotor-radius", "10",
                  "--mean-wind", "--out", str(d / "lidar.zarr")]):  # fmt: skip
        res = CliRunner().invoke(cli, args, prog_name="turbgen")
        assert res.exit_code in (0, 1), res.output  # lidar run: 1 = its coherence verdict, not an error
    shutil.copytree(d / "lidar.zarr", d / "nan.zarr")
    v = zarr.open_group(str(d / "nan.zarr"), mode="r+")["v_los"]
    v[...] = np.nan
    shutil.copytree(d / "lidar.zarr", d / "corrupt.zarr")
    chunks = sorted(p for p in (d / "corrupt.zarr" / "v_los" / "c").rglob("*") if p.is_file())
    chunks[0].write_bytes(b"not a zstd frame, garbage bytes")
    return d


@pytest.mark.parametrize("model", ["mann", "kaimal"])
@pytest.mark.parametrize("name, expected", [("nan.zarr", ["nan.zarr", "v_los has no value"]),
                                            ("corrupt.zarr", ["corrupt.zarr", "not a readable lidar dataset",
                                                              "Zstd"])])  # fmt: skip
def test_unusable_lidar_data_are_refused_in_one_line(datasets, model, name, expected):
    out = datasets / f"c_{model}.zarr"
    res = CliRunner().invoke(cli, [model, *GRID, "--seed", "2", "--constrain", str(datasets / name),
                                   "--out", str(out)], prog_name="turbgen")  # fmt: skip
    err = res.stderr.strip().splitlines()
    assert res.exit_code == 2, (res.exit_code, res.output[-2000:], repr(res.exception))
    assert len(err) == 1 and err[0].startswith("Error: ") and "Traceback" not in res.output, res.output[-2000:]
    for text in expected:
        assert text in err[0], (text, err[0])
    assert not out.exists()
