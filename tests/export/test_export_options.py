"""One set of export options, one request: `turbgen export`, turbgen.export() and ExportRequest(mean_wind=...) write
the same bytes for the same profile, veer and history; the options' refusals are one line (exit 2 on the CLI)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

import turbgen
from export_fixtures import make_store
from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.exporters import ExportRequest, export_store
from turbgen.exporters.options import ExportOptions, export_request
from turbgen.spec.mean_wind import MeanWind


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    folder = tmp_path_factory.mktemp("opts")
    path, _ = make_store(folder / "s.zarr")
    (folder / "hub.csv").write_text("0,9,0\n6,11,5\n")
    return path, folder / "hub.csv"


def test_cli_api_and_request_write_the_same_bytes(store, tmp_path):
    path, hub = store
    res = CliRunner().invoke(cli, ["export", str(path), "--format", "bts", "--out", str(tmp_path / "cli.bts"),
                                   "--profile", "log:z0=0.1,d=1", "--veer", "-0.3", "--mean-history", str(hub),
                                   "--no-runner-files"])
    assert res.exit_code == 0, res.output
    turbgen.export(path, "bts", tmp_path / "api.bts", profile="log:z0=0.1,d=1", veer=-0.3, mean_history=hub)
    wind = MeanWind(profile="log", roughness_m=0.1, displacement_m=1.0, veer_deg_per_m=-0.3,
                    history_times_s=(0.0, 6.0), history_speeds_m_s=(9.0, 11.0), history_directions_deg=(0.0, 5.0),
                    history_label="hub.csv")
    export_store(path, "bts", tmp_path / "lib.bts", ExportRequest(mean_wind=wind))
    lib = (tmp_path / "lib.bts").read_bytes()
    assert (tmp_path / "cli.bts").read_bytes() == lib and (tmp_path / "api.bts").read_bytes() == lib


def test_inline_rows_are_the_files_rows(store):
    path, _ = store
    from_file = export_request(path, "bts", ExportOptions(mean_history=str(store[1])))
    inline = export_request(path, "bts", ExportOptions(mean_history="0,9,0;6,11,5"), inline=True)
    assert from_file.mean_wind.history_speeds_m_s == inline.mean_wind.history_speeds_m_s == (9.0, 11.0)
    assert from_file.mean_wind.history_directions_deg == inline.mean_wind.history_directions_deg


@pytest.mark.parametrize("opts, message", [
    (ExportOptions(shear_exponent=0.1, profile="power:0.2"), "both set the profile"),
    (ExportOptions(iec_class="IIB"), "belong to --transient"),
    (ExportOptions(transient="EOG"), "needs --iec-class and --rotor-diameter"),
    (ExportOptions(transient="gust", iec_class="IIB", rotor_diameter_m=40.0), "is not one of EOG"),
    (ExportOptions(transient="EOG", iec_class="IIB", rotor_diameter_m=40.0, transient_sign="x"), "is not '+' or '-'"),
])
def test_refusals(store, opts, message):
    with pytest.raises(ParameterError, match=message.replace("+", r"\+")):
        export_request(store[0], "bts", opts)
