"""Reusable generators (turbgen.MannGenerator, turbgen.KaimalGenerator) and products of fields made in memory: the
fields of turbgen.mann / turbgen.kaimal to the bit, and validation, exports and the lidar without a store."""

import numpy as np
import pytest


import turbgen
from turbgen.api import fields, generator
from turbgen.errors import ParameterError
from turbgen.store import writer


def _same(a, b):
    for c in ("u", "v", "w"):
        np.testing.assert_array_equal(a[c].values, b[c].values)  # bit for bit
    assert {k: v for k, v in a.attrs.items() if k != "created_utc"} == \
        {k: v for k, v in b.attrs.items() if k != "created_utc"}


@pytest.fixture
def no_store_written(monkeypatch):
    """Fail any store created or any field routed through a temporary store."""
    def refuse(*args, **kwargs):
        raise AssertionError("a store was written")

    monkeypatch.setattr(writer, "create_store", refuse)
    monkeypatch.setattr(fields, "_through_store", refuse)


def test_acceptance_generator_field_is_turbgen_mann_and_validates_and_exports_in_memory(tmp_path, no_store_written):
    g = turbgen.MannGenerator(turbgen.MannParams(ae=0.1, length_scale_m=49, gamma=3.1, evo_time_s=400),
                              turbgen.Grid(nt=256, dt_s=0.5, x_m=(0, 50), ny=8, nz=8, dy_m=8, dz_m=8), U_m_s=16)
    a = g.field(seed=3)
    b = turbgen.mann(ae=0.1, L=49, gamma=3.1, evo=400, nt=256, ny=8, nz=8, dy=8, dz=8, planes=[0, 50], seed=3)
    _same(a, b)
    report = turbgen.validate(a)
    assert report.metrics and report.to_dict()["store"] == "the field in memory"
    path = tmp_path / "a.bts"
    result = turbgen.export(a, "bts", path)
    assert result.paths[0] == path and sorted(tmp_path.iterdir()) == sorted(result.paths)  # no store beside them
    bts = pytest.importorskip("weio").read(str(path))
    assert bts["u"].shape[1] == 256  # (component, t, y, z)


def test_in_memory_products_equal_the_stores(tmp_path):
    ds = turbgen.mann(nt=256, ny=16, nz=16, dy=8, gates="50:170:13.3", pad_yz=1, seed=5)
    stored = turbgen.mann(nt=256, ny=16, nz=16, dy=8, gates="50:170:13.3", pad_yz=1, seed=5, out=tmp_path / "m.zarr")
    report, lidar = turbgen.validate(ds), turbgen.lidar(ds)
    a, b = report.to_dict(), turbgen.validate(stored).to_dict()
    assert a.pop("store") == "the field in memory" and b.pop("store") == str(tmp_path / "m.zarr")
    a.pop("seconds"), b.pop("seconds")
    assert a == b
    la, lb = lidar.to_dict(), turbgen.lidar(stored).to_dict()
    assert la.keys() == lb.keys() and la["G_RL_simulated"] == lb["G_RL_simulated"]
    for result, text in ((report, report.table()), (lidar, lidar.text())):  # a notebook shows these, not the arrays
        assert repr(result) == text and len(text) < 5000
    turbgen.export(ds, "hdf5", tmp_path / "mem.h5")
    turbgen.export(stored, "hdf5", tmp_path / "store.h5")
    assert (tmp_path / "mem.h5").stat().st_size == (tmp_path / "store.h5").stat().st_size


def test_further_seeds_reuse_the_stencil(monkeypatch):
    g = turbgen.MannGenerator(turbgen.MannParams(ae=0.05, length_scale_m=30, gamma=3.1),
                              turbgen.Grid(nt=64, dt_s=0.5, x_m=(0, 40, 80), ny=8, nz=8, dy_m=8, dz_m=8), U_m_s=12,
                              pad_yz=1)
    import turbgen.runs.mann as runs_mann

    def no_build(*args, **kwargs):
        raise AssertionError("the stencil was built again")

    monkeypatch.setattr(runs_mann, "build_stencil", no_build)
    monkeypatch.setattr(runs_mann, "build_mann_stencil", no_build)
    fields_ = list(g.fields([1, 2]))
    assert [f.attrs["seed"] for f in fields_] == [1, 2] and g.nbytes > 0
    monkeypatch.undo()
    _same(fields_[1], turbgen.mann(ae=0.05, L=30, gamma=3.1, U=12, nt=64, ny=8, nz=8, dy=8, planes=[0, 40, 80],
                                   pad_yz=1, seed=2))


def test_single_frozen_plane_is_the_on_demand_field():
    g = turbgen.MannGenerator(turbgen.MannParams(ae=0.05, length_scale_m=30, gamma=3.1, evo_time_s=None),
                              turbgen.Grid(nt=64, dt_s=0.5, x_m=(0,), ny=8, nz=8, dy_m=8, dz_m=8), pad_yz=1)
    _same(g.field(seed=2), turbgen.mann(ae=0.05, L=30, gamma=3.1, evo="frozen", nt=64, ny=8, nz=8, dy=8, planes=[0],
                                        pad_yz=1, seed=2))


def test_generator_out_writes_the_store_of_the_command(tmp_path):
    g = turbgen.MannGenerator(turbgen.MannParams(ae=0.05, length_scale_m=30, gamma=3.1),
                              turbgen.Grid(nt=64, dt_s=0.5, x_m=(0, 40), ny=8, nz=8, dy_m=8, dz_m=8), pad_yz=1)
    stored = g.field(seed=4, out=tmp_path / "g.zarr")
    assert stored.encoding["source"] == str((tmp_path / "g.zarr").absolute())
    _same(stored.load(), g.field(seed=4))


def test_kaimal_generator_is_turbgen_kaimal():
    from turbgen.spec.kaimal import kaimal_params

    grid = turbgen.Grid(nt=128, dt_s=0.5, x_m=(0, 50, 100), ny=6, nz=6, dy_m=5, dz_m=5)
    g = turbgen.KaimalGenerator(kaimal_params(12.0, "A", 90.0), grid, U_m_s=12)
    a = g.field(seed=7)
    b = turbgen.kaimal(U=12, nt=128, ny=6, nz=6, dy=5, planes=[0, 50, 100], seed=7)
    for c in ("u", "v", "w"):
        np.testing.assert_array_equal(a[c].values, b[c].values)
    assert turbgen.validate(a).metrics


def test_kaimal_generator_builds_its_samplers_once(monkeypatch, tmp_path):
    from turbgen.spec.kaimal import kaimal_params
    from turbgen.synthesis import circulant, kaimal_evo

    grid = turbgen.Grid(nt=128, dt_s=0.5, x_m=(0, 50, 100), ny=6, nz=6, dy_m=5, dz_m=5)
    g = turbgen.KaimalGenerator(kaimal_params(12.0, "A", 90.0), grid, U_m_s=12, long_components="uvw",
                                vw_coherence="exp")
    first = g.field(seed=1)
    built = []
    monkeypatch.setattr(kaimal_evo, "embed_many", lambda *a, **k: built.append(1) or circulant.embed_many(*a, **k))
    monkeypatch.setattr(kaimal_evo, "longitudinal_factors",
                        lambda *a: built.append(1) or kaimal_evo.principal_sqrt(np.ones((1, 3, 3))))
    further = [g.field(seed=2), g.field(seed=3, out=tmp_path / "s3.zarr").load()]
    assert built == []  # neither samplers nor longitudinal factors made again
    monkeypatch.undo()
    for seed, ds in zip((2, 3), further):
        ref = turbgen.kaimal(U=12, nt=128, ny=6, nz=6, dy=5, planes=[0, 50, 100], seed=seed, long_components="uvw",
                             vw_coherence="exp")
        for c in ("u", "v", "w"):
            np.testing.assert_array_equal(ds[c].values, ref[c].values)
        assert ds.attrs["synthesis_report"] == first.attrs["synthesis_report"] == ref.attrs["synthesis_report"]


def test_bad_seed_is_one_line_parameter_error():
    g = turbgen.MannGenerator(turbgen.MannParams(ae=0.05, length_scale_m=30, gamma=3.1),
                              turbgen.Grid(nt=16, dt_s=0.5, x_m=(0,), ny=4, nz=4, dy_m=8, dz_m=8), pad_yz=1)
    with pytest.raises(ParameterError, match="seed") as err:
        g.field(seed=-1)
    assert "\n" not in str(err.value)


def test_objects_of_the_wrong_class_are_a_type_error_naming_them():
    grid = turbgen.Grid(nt=16, dt_s=0.5, x_m=(0,), ny=4, nz=4, dy_m=8, dz_m=8)
    mann = turbgen.MannParams(ae=0.05, length_scale_m=30, gamma=3.1)
    cases = [(lambda: turbgen.MannGenerator({"ae": 0.05}, grid), "params must be a turbgen.MannParams, not dict"),
             (lambda: turbgen.MannGenerator(mann, (16, 0.5)), "grid must be a turbgen.Grid, not tuple"),
             (lambda: turbgen.KaimalGenerator(mann, grid), "params must be a turbgen.KaimalParams, not MannParams")]
    for make, message in cases:
        with pytest.raises(TypeError, match=message):
            make()


def test_public_objects_are_the_library_classes():
    from turbgen.grid import Grid
    from turbgen.theory.params import KaimalParams, MannParams

    assert (turbgen.MannParams, turbgen.KaimalParams, turbgen.Grid) == (MannParams, KaimalParams, Grid)
    assert turbgen.MannGenerator is generator.MannGenerator and turbgen.KaimalGenerator is generator.KaimalGenerator
