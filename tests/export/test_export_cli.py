"""`turbgen export` on the command line: exit codes, refusals, no overwrite, atomic output."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from export_fixtures import make_store
from turbgen.cli import cli
from turbgen.exporters import ExportRequest, export_store
from turbgen.store import FieldStore


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path, _ = make_store(tmp_path_factory.mktemp("cli") / "s.zarr")
    return path


def run(*args):
    return CliRunner().invoke(cli, ["export", *map(str, args)])


@pytest.mark.parametrize("fmt,out,files,key", [
    ("bts", "f.bts", ["f.bts", "f_InflowWind_bts.dat"], "FileName_BTS"),
    ("wnd", "r", ["r.wnd", "r.sum", "r_InflowWind_wnd.dat"], "FilenameRoot"),
    ("evo", "lid.evo", ["lid.evo", "lid.wnd", "lid.sum", "lid_InflowWind_evo.dat", "lid_LidarSim_evolution.txt"],
     "EvolutionFlag"),
    ("hawc2", "box", ["box_u.bin", "box_v.bin", "box_w.bin", "box_InflowWind_hawc2.dat", "box_wind.htc"], "FileName_u"),
    ("mt4d", "f.mt4d", ["f.mt4d"], "not read by InflowWind"),
    ("hdf5", "f.h5", ["f.h5"], "not read by InflowWind"),
])
def test_each_format_writes_and_prints_inflowwind_lines(store, tmp_path, fmt, out, files, key):
    res = run(store, "--format", fmt, "--out", tmp_path / out)
    assert res.exit_code == 0, res.output
    assert key in res.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(files)  # no temporary files left


def test_windtype_lines(store, tmp_path):
    assert "3   WindType" in run(store, "--format", "bts", "--out", tmp_path / "a.bts").stdout
    assert "4   WindType" in run(store, "--format", "wnd", "--out", tmp_path / "a").stdout
    assert "5   WindType" in run(store, "--format", "hawc2", "--out", tmp_path / "a").stdout


def test_no_overwrite_without_flag(store, tmp_path):
    out = tmp_path / "f.bts"
    assert run(store, "--format", "bts", "--out", out).exit_code == 0
    before = out.read_bytes()
    res = run(store, "--format", "bts", "--out", out, "--shear-exponent", "0.1")
    assert res.exit_code == 2 and "--overwrite" in res.output
    assert out.read_bytes() == before
    res = run(store, "--format", "bts", "--out", out, "--shear-exponent", "0.1", "--overwrite")
    assert res.exit_code == 0 and out.read_bytes() != before


def test_partial_existing_output_set_is_refused(store, tmp_path):
    (tmp_path / "lid.sum").write_text("someone's file\n")
    res = run(store, "--format", "evo", "--out", tmp_path / "lid")
    assert res.exit_code == 2 and "lid.sum" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lid.sum"]
    assert (tmp_path / "lid.sum").read_text() == "someone's file\n"


def test_incomplete_and_missing_store_exit_2(store, tmp_path):
    import shutil

    broken = tmp_path / "broken.zarr"
    shutil.copytree(store, broken)
    meta = json.loads((broken / "zarr.json").read_text())
    del meta["attributes"]["turbgen_complete"]
    (broken / "zarr.json").write_text(json.dumps(meta))
    res = run(broken, "--format", "bts", "--out", tmp_path / "f.bts")
    assert res.exit_code == 2 and "incomplete" in res.output
    assert len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "f.bts").exists()
    res = run(tmp_path / "nothing.zarr", "--format", "hdf5", "--out", tmp_path / "f.h5")
    assert res.exit_code == 2 and not (tmp_path / "f.h5").exists()


def test_below_ground_exit_2_then_drop(tmp_path):
    path, _ = make_store(tmp_path / "low.zarr", hub_height_m=5.0)  # rows at -4, -1, 2, ... m
    res = run(path, "--format", "wnd", "--out", tmp_path / "low")
    assert res.exit_code == 2 and "ground" in res.output and "--drop-below-ground" in res.output
    assert not (tmp_path / "low.wnd").exists() and not (tmp_path / "low.sum").exists()
    res = run(path, "--format", "wnd", "--out", tmp_path / "low", "--drop-below-ground")
    assert res.exit_code == 0 and "dropped the 2" in res.output
    res = run(path, "--format", "bts", "--out", tmp_path / "hi.bts", "--hub-height", "40")
    assert res.exit_code == 0


@pytest.mark.parametrize("args,msg", [
    (["--plane", "3"], "plane"),
    (["--shear-exponent", "2"], "shear exponent"),
    (["--hub-height", "-5"], "hub height"),
    (["--hub-height", "0.5"], "[1, 1000]"),  # the README's range of hub heights, as for the generators
    (["--hub-height", "1e9"], "[1, 1000]"),
])
def test_bad_options_exit_2(store, tmp_path, args, msg):
    res = run(store, "--format", "bts", "--out", tmp_path / "f.bts", *args)
    assert res.exit_code == 2 and msg in res.output
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("fmt,args", [
    ("hawc2", ["--tower"]),
    ("hawc2", ["--no-periodic"]),
    ("hdf5", ["--plane", "1"]),
    ("mt4d", ["--shear-exponent", "0.1"]),
    ("hdf5", ["--shear-exponent", "0.2"]),  # the default value, typed: still ignored by hdf5, so refused
    ("mt4d", ["--drop-below-ground"]),
])
def test_options_a_format_would_ignore_are_refused(store, tmp_path, fmt, args):
    res = run(store, "--format", fmt, "--out", tmp_path / "b", *args)
    assert res.exit_code == 2 and args[0] in res.output
    assert not list(tmp_path.iterdir())


def test_interrupted_export_leaves_nothing(store, tmp_path, monkeypatch):
    real = FieldStore.read_plane

    def failing(self, component, ix):
        if ix == 2:
            raise KeyboardInterrupt
        return real(self, component, ix)

    monkeypatch.setattr(FieldStore, "read_plane", failing)
    with pytest.raises(KeyboardInterrupt):
        export_store(store, "evo", tmp_path / "lid", ExportRequest())
    assert not list(tmp_path.iterdir())


def test_rotorless_store_needs_plane(tmp_path):
    path, _ = make_store(tmp_path / "up.zarr", x_m=(10.0, 20.0))
    res = run(path, "--format", "bts", "--out", tmp_path / "f.bts")
    assert res.exit_code == 2 and "--plane" in res.output
    assert run(path, "--format", "bts", "--out", tmp_path / "f.bts", "--plane", "1").exit_code == 0


@pytest.mark.parametrize("fmt,exts", [("wnd", [".wnd", ".sum"]), ("evo", [".evo", ".wnd", ".sum"])])
def test_root_with_a_dot_keeps_its_whole_name(store, tmp_path, fmt, exts):
    """InflowWind opens FilenameRoot + '.wnd'/'.sum': a root such as case_U16.5 must give case_U16.5.wnd,
    the name the printed FilenameRoot line loads (it gave case_U16.wnd, which InflowWind never opens)."""
    res = run(store, "--format", fmt, "--out", tmp_path / "case_U16.5", "--no-runner-files")
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"case_U16.5{e}" for e in exts)
    assert f'"{tmp_path / "case_U16.5"}"   FilenameRoot' in res.stdout
    if fmt == "evo":
        assert f'"{tmp_path / "case_U16.5.evo"}"' in res.stdout
    # an extension of the format itself is still dropped
    res = run(store, "--format", fmt, "--out", tmp_path / f"b.{fmt}")
    assert res.exit_code == 0 and (tmp_path / "b.wnd").exists() and (tmp_path / "b.sum").exists()


@pytest.mark.parametrize("fmt,name", [("bts", "zarr.json"), ("wnd", "u/root"), ("hdf5", "f.h5")])
def test_output_inside_the_source_store_is_refused(tmp_path, fmt, name):
    """`--out STORE/zarr.json --overwrite` replaced the store's metadata with the export (the store was
    lost); any file written into the store's directory tree is refused, even with --overwrite."""
    path, _ = make_store(tmp_path / "s.zarr")
    before = {p: p.read_bytes() for p in path.rglob("*") if p.is_file()}
    res = run(path, "--format", fmt, "--out", path / name, "--overwrite")
    assert res.exit_code == 2 and "inside the store" in res.output
    assert len(res.output.strip().splitlines()) == 1
    assert {p: p.read_bytes() for p in path.rglob("*") if p.is_file()} == before
    assert run(path, "--format", "bts", "--out", tmp_path / "s.zarr.bts").exit_code == 0  # beside it: fine


def test_out_naming_a_directory_is_refused(store, tmp_path):
    # `--out newdir/` wrote a FILE named newdir (the trailing separator was dropped)
    res = run(store, "--format", "bts", "--out", f"{tmp_path / 'newdir'}/")
    assert res.exit_code == 2 and "newdir/" in res.output
    assert not list(tmp_path.iterdir())
