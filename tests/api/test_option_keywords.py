"""The API keywords added for the commands' options: kaimal(constrain=...), a lidar report in memory as a
constraint, validate(plots=), lidar(plots=, profile=), info(), export's runner files by default."""

import numpy as np
from click.testing import CliRunner

import turbgen
from turbgen.cli import cli

MAST = __import__("pathlib").Path(turbgen.__file__).parents[1] / "examples" / "mast.json"
KAIMAL = {"nt": 64, "ny": 4, "nz": 4, "dy": 10.0, "planes": [0, 40], "threads": 1}
KAIMAL_ARGS = ["--nt", "64", "--ny", "4", "--nz", "4", "--dy", "10", "--planes", "0,40", "--threads", "1"]


def _same_values(a, b):
    for c in ("u", "v", "w"):
        np.testing.assert_array_equal(a[c].values, b[c].values)


def test_kaimal_constrain_is_the_command_and_leaves_no_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    api = turbgen.kaimal(U=12, seed=3, constrain=[MAST], noise=0.05, **KAIMAL)
    res = CliRunner().invoke(cli, ["kaimal", "--U", "12", "--seed", "3", "--constrain", str(MAST), "--noise", "0.05",
                                   *KAIMAL_ARGS, "--out", "cli.zarr"])  # fmt: skip
    assert res.exit_code == 0, res.output
    _same_values(api, turbgen.open_store("cli.zarr"))
    assert api.attrs["constraints"]["n_samples"] > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cli.zarr"]  # the temporary store was removed


def test_a_lidar_report_in_memory_constrains_as_its_written_dataset(tmp_path):
    grid = {"nt": 256, "ny": 16, "nz": 16, "dy": 8, "gates": "50:170:13.3", "pad_yz": 1}
    truth = turbgen.mann(seed=1, **grid)
    report = turbgen.lidar(truth, out=tmp_path / "lidar.zarr")
    from_memory = turbgen.mann(seed=2, constrain=[report], **grid)
    from_file = turbgen.mann(seed=2, constrain=[tmp_path / "lidar.zarr"], **grid)
    _same_values(from_memory, from_file)
    assert from_memory.attrs["constraints"]["residual_rms_m_s"] < 1e-3


def test_plots_keywords_write_the_commands_figures(tmp_path):
    import matplotlib
    import matplotlib.pyplot as plt

    backend, figures = matplotlib.get_backend(), plt.get_fignums()
    matplotlib.use("svg")  # as a notebook's inline backend: the library's plots must not switch it to Agg
    try:
        ds = turbgen.mann(nt=256, ny=16, nz=16, dy=8, gates="50:170:13.3", pad_yz=1)
        turbgen.validate(ds, plots=tmp_path / "v")
        assert any((tmp_path / "v").glob("*.png"))
        report = turbgen.lidar(ds, plots=tmp_path / "l", mean_wind=True, profile="log:z0=0.03")
        assert [p.name for p in (tmp_path / "l").glob("*.png")] == ["lidar_coherence.png"]
        assert report.to_dict()["lidar"] and report.run.samples.mean_wind_added
        assert matplotlib.get_backend() == "svg" and plt.get_fignums() == figures  # nothing left open in pyplot
    finally:
        matplotlib.use(backend)


def test_info_of_a_field_in_memory_and_of_an_export(tmp_path):
    ds = turbgen.kaimal(**KAIMAL)
    summary = turbgen.info(ds)
    assert summary["path"] is None and summary["size_on_disk_bytes"] == 0 and summary["chunks_decoded"]
    result = turbgen.export(ds, "bts", tmp_path / "k.bts")
    assert len(result.paths) == 2 and result.paths[1].name == "k_InflowWind_bts.dat"  # runner files by default
    assert dict(turbgen.info(tmp_path / "k.bts"))  # the export's header rows, as turbgen info shows them


def test_kaimal_constrain_in_memory_is_the_field_written_with_out(tmp_path, monkeypatch):
    from turbgen.runs import constrain_kaimal

    def refuse(*args, **kwargs):
        raise AssertionError("a temporary store was written")

    monkeypatch.setattr(constrain_kaimal, "create_store", refuse)  # in memory: no store, not even a temporary one
    api = turbgen.kaimal(U=12, seed=3, constrain=[MAST], conditional_mean=False, **KAIMAL)
    monkeypatch.undo()
    written = turbgen.kaimal(U=12, seed=3, constrain=[MAST], out=tmp_path / "k.zarr", **KAIMAL)
    _same_values(api, written)
    mine = {k: v for k, v in api.attrs.items() if k != "created_utc"}
    assert mine == {k: v for k, v in written.attrs.items() if k != "created_utc"}
    assert api.attrs["constraints"]["residual_rms_m_s"] < 0.5
