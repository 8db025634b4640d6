"""The runners' input files written beside the wind files: the InflowWind v5 input file parsed by
openfast-io (OpenFAST's own reader of that file), its wind-file names resolved from its own folder
wherever the export ran; the HAWC2 wind block; the start shift of non-periodic files stated."""

from __future__ import annotations

import os
import shlex
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from export_fixtures import make_store
from turbgen.cli import cli
from turbgen.exporters import ExportRequest, export_store, read_bts

reader = pytest.importorskip("openfast_io.FAST_reader")
HUB, U = 20.0, 10.0


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return make_store(tmp_path_factory.mktemp("rf") / "s.zarr", hub_height_m=HUB, U_m_s=U)


def parse(dat: Path) -> dict:
    """The input file as openfast-io reads it, run from an unrelated folder (paths joined to the file's own)."""
    r = reader.InputReader_OpenFAST()
    r.FAST_directory = str(dat.parent)
    r.fst_vt["Fst"]["InflowFile"] = dat.name
    r.read_InflowWind()
    return r.fst_vt["InflowWind"]


def test_bts_input_file_resolves_from_its_folder(store, tmp_path, monkeypatch):
    path, _ = store
    (tmp_path / "run" / "wind").mkdir(parents=True)
    monkeypatch.chdir(tmp_path / "run")  # the export runs here, with a relative --out
    r = export_store(path, "bts", "wind/f.bts", ExportRequest(runner_files=True))
    dat = tmp_path / "run" / "wind" / "f_InflowWind_bts.dat"
    assert [Path(p).name for p in r.paths] == ["f.bts", dat.name]
    assert '"f.bts"' in dat.read_text()  # relative to the input file, not to where the export ran
    monkeypatch.chdir(tmp_path)
    ifw = parse(dat)
    assert ifw["WindType"] == 3 and ifw["RefHt"] == HUB and ifw["PropagationDir"] == 0.0
    assert Path(ifw["FileName_BTS"]).resolve() == (tmp_path / "run" / "wind" / "f.bts").resolve()
    assert read_bts(ifw["FileName_BTS"])["U_m_s"] == U
    assert r.usage and "InflowFile" in r.usage[0]


def test_wnd_input_file(store, tmp_path):
    path, _ = store
    export_store(path, "wnd", tmp_path / "case_U10.5", ExportRequest(runner_files=True, periodic=False))
    dat = tmp_path / "case_U10.5_InflowWind_wnd.dat"
    ifw = parse(dat)
    assert ifw["WindType"] == 4 and ifw["TowerFile"] is False
    root = Path(ifw["FileNameRoot"])
    assert Path(str(root) + ".wnd").is_file() and Path(str(root) + ".sum").is_file()
    assert dat.read_text().splitlines()[1].startswith("NOT PERIODIC: starts 0.4 s upstream")


def read_evolution_section(path: Path) -> tuple[list[str], list[str]]:
    """The section as the fork's LidarSim reader takes it: '!' lines skipped, then by position the
    separator and the first token (list-directed: a quoted string is one token) of the next two lines."""
    lines = [ln for ln in path.read_text().splitlines() if not ln.lstrip().startswith("!")]
    assert len(lines) == 3
    return [lines[0], *(shlex.split(ln)[0] for ln in lines[1:])], [ln.split()[1] for ln in lines[1:]]


def test_evo_input_file_and_lidarsim_section(store, tmp_path, monkeypatch):
    path, _ = store
    (tmp_path / "run" / "wind").mkdir(parents=True)
    monkeypatch.chdir(tmp_path / "run")  # the export runs here, with a relative --out
    r = export_store(path, "evo", "wind/lid", ExportRequest(runner_files=True))
    wind = tmp_path / "run" / "wind"
    assert [Path(p).name for p in r.paths] == ["lid.evo", "lid.wnd", "lid.sum", "lid_InflowWind_evo.dat",
                                               "lid_LidarSim_evolution.txt"]
    monkeypatch.chdir(tmp_path)  # read from elsewhere: both files' paths must still resolve
    ifw = parse(wind / "lid_InflowWind_evo.dat")  # the wnd export's file, for the rotor-plane .wnd
    assert ifw["WindType"] == 4 and ifw["RefHt"] == HUB and ifw["TowerFile"] is False
    root = Path(ifw["FileNameRoot"])
    assert Path(str(root) + ".wnd").resolve() == (wind / "lid.wnd").resolve()
    assert Path(str(root) + ".sum").resolve() == (wind / "lid.sum").resolve()
    (sep, flag, evo), keys = read_evolution_section(wind / "lid_LidarSim_evolution.txt")
    assert "Wind Evolution" in sep and keys == ["EvolutionFlag", "EvolutionFilenameRoot"] and flag == "True"
    assert Path(evo).is_absolute() and Path(evo).resolve() == (wind / "lid.evo").resolve()
    assert all(Path(evo).with_suffix(ext).is_file() for ext in (".wnd", ".sum"))  # the fork's ROOT = path - .evo
    assert len(r.usage) == 2 and "InflowFile" in r.usage[0] and r.usage[1].startswith("LidarSim (FUAS fork): paste")
    assert evo in "\n".join(r.inflowwind_lines)  # the printed lines give the same absolute path


def test_existing_lidarsim_section_is_not_overwritten(store, tmp_path):
    path, _ = store
    (tmp_path / "lid_LidarSim_evolution.txt").write_text("mine\n")
    res = CliRunner().invoke(cli, ["export", str(path), "--format", "evo", "--out", str(tmp_path / "lid")])
    assert res.exit_code == 2 and "lid_LidarSim_evolution.txt" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lid_LidarSim_evolution.txt"]
    res = CliRunner().invoke(cli, ["export", str(path), "--format", "evo", "--out", str(tmp_path / "lid"),
                                   "--overwrite"])
    assert res.exit_code == 0 and "use: LidarSim (FUAS fork): paste" in res.output
    assert "EvolutionFlag" in (tmp_path / "lid_LidarSim_evolution.txt").read_text()


def test_hawc2_input_file_and_htc_block(store, tmp_path):
    path, _ = store
    r = export_store(path, "hawc2", tmp_path / "box", ExportRequest(runner_files=True))
    ifw = parse(tmp_path / "box_InflowWind_hawc2.dat")
    assert ifw["WindType"] == 5 and ifw["ScaleMethod"] == 0 and ifw["WindProfile"] == 0 and ifw["URef"] == U
    assert (ifw["nx"], ifw["ny"], ifw["nz"]) == (64, 5, 7)
    assert ifw["dx"] == pytest.approx(U * 0.1) and (ifw["dy"], ifw["dz"]) == (2.0, 3.0)
    assert ifw["RefHt_Hawc"] == HUB  # the grid centre (7 rows centred on the hub)
    for c in "uvw":
        assert Path(ifw[f"FileName_{c}"]) == tmp_path / f"box_{c}.bin"
        size = os.path.getsize(ifw[f"FileName_{c}"])
        assert size == 4 * ifw["nx"] * ifw["ny"] * ifw["nz"]  # the keys describe the boxes as written
    htc = (tmp_path / "box_wind.htc").read_text()
    for line in ("begin wind ;", "wsp 10 ;", "center_pos0 0.0 0.0 -20 ;", "shear_format 1 0 ;", "turb_format 1 ;",
                 "filename_u ./box_u.bin ;", "box_dim_u 64 1 ;", "box_dim_v 5 2 ;", "box_dim_w 7 3 ;",
                 "dont_scale 1 ;", "end mann ;", "end wind ;"):
        assert line in htc
    tint = float(htc.split("tint ")[1].split()[0])
    u = np.fromfile(tmp_path / "box_u.bin", "<f4")  # u - URef with the profile: its sigma exceeds the box tint
    assert 0.05 < tint < u.std() / U
    assert len(r.usage) == 2 and r.usage[1].startswith("HAWC2: paste")


def test_cli_writes_them_by_default_and_says_how_to_use_them(store, tmp_path):
    path, _ = store
    res = CliRunner().invoke(cli, ["export", str(path), "--format", "bts", "--out", str(tmp_path / "a.bts"),
                                   "--no-periodic"])
    assert res.exit_code == 0, res.output
    assert "use: OpenFAST: set InflowFile" in res.output
    assert "not periodic: InflowWind starts the file 0.4 s upstream" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.bts", "a_InflowWind_bts.dat"]
    res = CliRunner().invoke(cli, ["export", str(path), "--format", "bts", "--out", str(tmp_path / "b.bts"),
                                   "--no-runner-files"])
    assert res.exit_code == 0 and not (tmp_path / "b_InflowWind_bts.dat").exists()


def test_existing_input_file_is_not_overwritten(store, tmp_path):
    path, _ = store
    (tmp_path / "f_InflowWind_bts.dat").write_text("mine\n")
    res = CliRunner().invoke(cli, ["export", str(path), "--format", "bts", "--out", str(tmp_path / "f.bts")])
    assert res.exit_code == 2 and "f_InflowWind_bts.dat" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f_InflowWind_bts.dat"]


def test_runner_files_refused_where_there_is_none(store, tmp_path):
    from turbgen.errors import ParameterError

    with pytest.raises(ParameterError, match="runner_files"):
        export_store(store[0], "mt4d", tmp_path / "e.mt4d", ExportRequest(runner_files=True))
