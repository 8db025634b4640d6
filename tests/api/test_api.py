"""The Python API (turbgen.mann, kaimal, open_store, validate, export, lidar): the CLI's fields to the bit, keywords
resolved from the run schemas, one-line ParameterErrors, and its docstring examples."""

import doctest
import json

import numpy as np
import pytest
from click.testing import CliRunner

import turbgen
from turbgen.api import fields, generator, products
from turbgen.spec.run_mapping import run_inputs
from turbgen.cli import cli
from turbgen.errors import ParameterError, StoreError

MANN_SMALL = {"nt": 64, "ny": 8, "nz": 8, "dy": 8.0, "planes": [0, 40, 80], "pad_yz": 1}
MANN_ARGS = ["--nt", "64", "--ny", "8", "--nz", "8", "--dy", "8", "--planes", "0,40,80", "--pad-yz", "1"]


def _cli_field(tmp_path, args, name="cli.zarr"):
    out = tmp_path / name
    r = CliRunner().invoke(cli, [*args, "--out", str(out)])
    assert r.exit_code == 0, r.output
    return turbgen.open_store(out)


def _assert_same_field(a, b):
    for c in ("u", "v", "w"):
        np.testing.assert_array_equal(a[c].values, b[c].values)  # bit for bit, not within a tolerance
    assert a.attrs["parameters"] == b.attrs["parameters"]
    assert a.attrs["grid"] == b.attrs["grid"]


def test_mann_in_memory_is_the_cli_field(tmp_path):
    api = turbgen.mann(L=30, gamma=2.5, evo=200, seed=4, U=12, ti=0.15, **MANN_SMALL)
    cli_ds = _cli_field(tmp_path, ["mann", "--L", "30", "--gamma", "2.5", "--evo", "200", "--seed", "4", "--U", "12",
                                   "--ti", "0.15", *MANN_ARGS])
    _assert_same_field(api, cli_ds)
    assert list(tmp_path.iterdir()) == [tmp_path / "cli.zarr"]  # nothing else written by the API


def _assert_same_dataset(memory, stored):
    """The in-memory Dataset is what xarray.open_zarr of the store loads: values to the bit, coordinates, dtypes and
    every attribute (of the field, its variables and coordinates) but the creation time."""
    assert dict(memory.sizes) == dict(stored.sizes) and list(memory.data_vars) == list(stored.data_vars)
    for name in [*memory.data_vars, *memory.coords]:
        assert memory[name].dims == stored[name].dims and memory[name].dtype == stored[name].dtype, name
        np.testing.assert_array_equal(memory[name].values, stored[name].values)
        assert memory[name].attrs == stored[name].attrs, name
    differing = {k for k in memory.attrs.keys() | stored.attrs.keys() if memory.attrs.get(k) != stored.attrs.get(k)}
    assert differing <= {"created_utc"}, differing


def _no_store(*args, **kwargs):
    raise AssertionError("the field went through a store")


def test_mann_in_memory_is_the_cli_store_without_writing_one(tmp_path, monkeypatch):
    monkeypatch.setattr(fields, "_through_store", _no_store)
    api = turbgen.mann(L=30, gamma=2.5, evo=200, seed=4, U=12, ti=0.15, **MANN_SMALL)
    cli_ds = _cli_field(tmp_path, ["mann", "--L", "30", "--gamma", "2.5", "--evo", "200", "--seed", "4", "--U", "12",
                                   "--ti", "0.15", *MANN_ARGS])
    _assert_same_dataset(api, cli_ds.load())
    frozen = turbgen.mann(evo="frozen", nt=64, ny=8, nz=8, dy=8, planes=[0], pad_yz=1, seed=2)  # on-demand stencil
    _assert_same_dataset(frozen, _cli_field(tmp_path, ["mann", "--evo", "frozen", "--nt", "64", "--ny", "8", "--nz",
                                                       "8", "--dy", "8", "--planes", "0", "--pad-yz", "1", "--seed",
                                                       "2"], "frozen.zarr").load())


def test_a_mann_field_that_does_not_fit_with_its_run_goes_through_a_store(monkeypatch):
    from turbgen.runs.mann import memory_estimate_bytes
    from turbgen.runs.mann_outofcore import base_bytes
    from turbgen.spec.mann import MannRun

    run = MannRun.from_mapping({"grid": {"nt": 64, "ny": 8, "nz": 8, "dy_m": 8.0, "x_m": [0, 40, 80]}, "pad_yz": 1})
    need = memory_estimate_bytes(run, 2) + 3 * run.grid.nbytes_per_component()
    # base_bytes: what the process holds (resident memory now), so the budget is taken with a margin of 1 MiB
    assert fields._mann_fits(run, 2, None, need + base_bytes() + 2**20)
    assert not fields._mann_fits(run, 2, None, need + base_bytes() - 2**20)
    direct = turbgen.mann(**MANN_SMALL)
    monkeypatch.setattr(fields, "_mann_fits", lambda *args: False)
    _assert_same_dataset(direct, turbgen.mann(**MANN_SMALL))


def test_kaimal_in_memory_is_the_cli_store_and_falls_back_to_a_store(tmp_path, monkeypatch):
    args = {"U": 12, "seed": 3, "nt": 128, "ny": 6, "nz": 6, "planes": [0, 50]}
    with monkeypatch.context() as m:
        m.setattr(fields, "_through_store", _no_store)
        api = turbgen.kaimal(**args)
    cli_ds = _cli_field(tmp_path, ["kaimal", "--U", "12", "--seed", "3", "--nt", "128", "--ny", "6", "--nz", "6",
                                   "--planes", "0,50"])
    _assert_same_dataset(api, cli_ds.load())
    monkeypatch.setattr(fields, "available_memory_bytes", lambda: 1000)  # too little: through a store
    _assert_same_dataset(api, turbgen.kaimal(**args))


def test_mann_preset_config_and_options_merge_as_in_the_cli(tmp_path):
    # run file < preset < keywords: the file's L is replaced by the preset's, the preset's gamma by the keyword
    config = tmp_path / "run.json"
    config.write_text(json.dumps({"length_scale_m": 60, "seed": 7, "grid": {"nt": 64, "ny": 8, "nz": 8, "dy_m": 8}}))
    api = turbgen.mann(config=config, preset="stable", gamma=2.0, planes=[0, 40], pad_yz=1, evo="frozen",
                       out=tmp_path / "api.zarr")
    cli_ds = _cli_field(tmp_path, ["mann", "--config", str(config), "--preset", "stable", "--gamma", "2",
                                   "--planes", "0,40", "--pad-yz", "1", "--evo", "frozen"])
    _assert_same_field(api, cli_ds)
    p = api.attrs["parameters"]
    assert (p["length_scale_m"], p["gamma"], p["evo_time_s"], api.attrs["seed"]) == (30.0, 2.0, None, 7)
    assert api.encoding["source"].endswith("api.zarr")


def test_gates_text_gives_the_cli_planes(tmp_path):
    api = turbgen.mann(gates="50:100:13.3", nt=64, ny=8, nz=8, dy=8, pad_yz=1)
    cli_ds = _cli_field(tmp_path, ["mann", "--gates", "50:100:13.3", "--nt", "64", "--ny", "8", "--nz", "8",
                                   "--dy", "8", "--pad-yz", "1"])
    _assert_same_field(api, cli_ds)
    assert api.x.values.tolist() == [0.0, 50.0, 63.3, 76.6, 89.9]


def test_kaimal_preset_is_the_cli_field(tmp_path):
    api = turbgen.kaimal(U=12, preset="unstable", turb_class="B", seed=3, nt=128, ny=6, nz=6, planes=[0, 50])
    cli_ds = _cli_field(tmp_path, ["kaimal", "--U", "12", "--preset", "unstable", "--class", "B", "--seed", "3",
                                   "--nt", "128", "--ny", "6", "--nz", "6", "--planes", "0,50"])
    _assert_same_field(api, cli_ds)


def test_keywords_are_the_option_names_and_run_file_keys_go_in_config(tmp_path):
    given, grid, x_m = run_inputs("mann", {"L": 30, "dt": 0.25, "evo": "frozen", "conditional_mean": False})
    assert given == {"length_scale_m": 30, "evo_time_s": None} and grid == {"dt_s": 0.25} and x_m is None
    with pytest.raises(TypeError, match="length_scale_m"):
        turbgen.mann(length_scale_m=30)
    _assert_same_field(turbgen.mann(config={"length_scale_m": 30, "grid": {"dt_s": 0.25}}, **MANN_SMALL),
                       turbgen.mann(L=30, dt=0.25, **MANN_SMALL))


@pytest.mark.parametrize("call, message", [
    (lambda: turbgen.mann(ae=0.1, ti=0.1), "give one of `ae`, `sigma_u`, `ti`"),
    (lambda: turbgen.kaimal(noise=0.1), "`noise` and `conditional_mean` need `constrain`"),
    (lambda: turbgen.mann(planes=[0], gates=[50]), "give `planes` or `gates`, not both"),
    (lambda: turbgen.mann(gates="50:10:1"), "step > 0 and stop >= start"),
    (lambda: turbgen.mann(nt=1), "nt = 1 is outside the allowed range"),
    (lambda: turbgen.mann(L=-5), "outside the allowed range"),
    (lambda: turbgen.kaimal(presets_file="p.toml"), "`presets_file` needs `preset`"),
])  # fmt: skip
def test_bad_input_is_one_line_parameter_error(call, message):
    with pytest.raises(ParameterError) as err:
        call()
    assert message in str(err.value) and "\n" not in str(err.value)


def test_products_refuse_what_is_not_a_field(tmp_path):
    with pytest.raises(StoreError, match="not a complete turbgen field"):
        turbgen.validate(turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 50]).drop_attrs())
    with pytest.raises(StoreError):
        turbgen.export(tmp_path / "missing.zarr", "bts", tmp_path / "x.bts")
    with pytest.raises(ParameterError, match="format = 'csv'"):
        turbgen.export(turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 50], out=tmp_path / "k.zarr"), "csv",
                       tmp_path / "x.csv")


def test_existing_out_is_not_replaced_without_overwrite(tmp_path):
    out = tmp_path / "k.zarr"
    first = turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 50], out=out).u.values
    with pytest.raises(StoreError, match="overwrite"):
        turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 50], seed=2, out=out)
    np.testing.assert_array_equal(turbgen.open_store(out).u.values, first)


def test_product_names_are_functions_beside_their_packages():
    import turbgen.validation.report  # importing a package behind a product leaves the product's name alone

    assert callable(turbgen.validate) and callable(turbgen.export) and callable(turbgen.lidar)
    assert turbgen.validate.__module__ == "turbgen.api.products"
    assert "bts" in turbgen.exporters.EXPORTERS
    assert "store" in str(__import__("inspect").signature(turbgen.lidar))


@pytest.mark.parametrize("module", [turbgen, fields, products, generator])
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0
    assert module is turbgen or result.attempted > 0


def test_theory_namespace_names_resolve_and_its_examples_run():
    import turbgen.theory as theory

    for name in theory.__all__:
        assert callable(getattr(theory, name)), name
    assert doctest.testmod(theory).failed == 0
