"""turbgen.spec: one description of a run (defaults, energy level, store attributes) and the model registry."""

from __future__ import annotations

import pytest

from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.runs.models import MODELS, get_model
from turbgen.spec.defaults import KAIMAL_GRID, MANN_GRID, grid_from_mapping
from turbgen.spec.energy import resolve_ae
from turbgen.spec.kaimal import KaimalRun
from turbgen.spec.mann import MannRun
from turbgen.spec.preset_runs import mann_params_for, mann_run_keys
from turbgen.theory.kaimal import iec_sigma1_m_s
from turbgen.theory.mann_spectra import ae_for_sigma_u
from turbgen.theory.params import MannParams

SMALL = {"nt": 32, "dt_s": 0.5, "x_m": [0.0, 50.0], "ny": 4, "nz": 4, "dy_m": 6.0}


def test_dz_defaults_to_dy_and_missing_keys_take_the_model_grid():
    g = grid_from_mapping({"dy_m": 3.0}, MANN_GRID)
    assert (g.nt, g.ny, g.dy_m, g.dz_m) == (MANN_GRID["nt"], MANN_GRID["ny"], 3.0, 3.0)
    g = grid_from_mapping({"dz_m": 2.0}, KAIMAL_GRID)
    assert (g.dy_m, g.dz_m) == (KAIMAL_GRID["dy_m"], 2.0)
    given = Grid(8, 1.0, (0.0,), 2, 2, 1.0, 1.0)
    assert grid_from_mapping(given, MANN_GRID) is given


def test_energy_level_precedence_and_the_iec_class():
    shape = MannParams(1.0, 49.0, 3.1, evo_time_s=400.0)
    assert resolve_ae(shape, 16.0, ae=0.3, ti=0.1) == (0.3, "ae")  # ae first
    ae, how = resolve_ae(shape, 10.0, sigma_u_m_s=1.5, ti=0.3)  # then sigma_u
    assert ae == ae_for_sigma_u(1.5, shape) and "sigma_u = 1.5" in how
    assert resolve_ae(shape, 10.0, ti=0.15)[0] == ae_for_sigma_u(1.5, shape)
    assert resolve_ae(shape, 12.0, turb_class="B")[0] == ae_for_sigma_u(iec_sigma1_m_s(12.0, "B"), shape)
    with pytest.raises(ParameterError, match="turb_class"):
        resolve_ae(shape, 12.0, turb_class="Z")


def test_preset_path_is_the_run_mapping_the_cli_and_sweep_take():
    # mann_params_for resolves mann_run_keys through MannRun.from_mapping, as --preset and the sweep do
    run = MannRun.from_mapping({**mann_run_keys("stable"), "U_m_s": 9.0, "grid": SMALL})
    assert mann_params_for("stable", 9.0) == run.params
    assert run.ae_from.startswith("model sigma_u: IEC class A")


def test_derived_values_have_their_own_attribute_and_old_stores_still_read():
    run = MannRun.from_mapping({"sigma_u_m_s": 1.2, "grid": SMALL, "seed": 4})
    attrs = {**run.to_attrs(), "grid": {**SMALL, "dz_m": 6.0}}
    assert "ae_from" not in attrs["parameters"] and attrs["derived"]["ae_from"] == run.ae_from
    assert MannRun.from_attrs(attrs) == run
    old = {**attrs, "parameters": {**attrs["parameters"], **attrs.pop("derived")}}  # ae_from among the parameters
    assert MannRun.from_attrs(old) == run

    k = KaimalRun.from_mapping({"U_m_s": 12.0, "grid": SMALL, "long_model": "simley-pao"})
    attrs = {**k.to_attrs({"expected_sigma_m_s": [1.0, 0.8, 0.5]}), "grid": {**SMALL, "dz_m": 6.0}}
    assert set(attrs["derived"]) == {"effective_long_parameters", "expected_sigma_m_s"}
    assert not set(attrs["parameters"]) & set(attrs["derived"])
    assert KaimalRun.from_attrs(attrs) == k
    old = {**attrs, "parameters": {**attrs["parameters"], **attrs.pop("derived"), "freq_chunk": 64}}
    assert KaimalRun.from_attrs(old) == k
    with pytest.raises(ParameterError, match="not a turbgen Kaimal store"):
        KaimalRun.from_attrs({"parameters": {}})


def test_registry_names_each_model_once():
    assert set(MODELS) == {"mann", "kaimal"}
    for name, model in MODELS.items():
        assert model.name == name and get_model(name) is model
        run = model.spec.from_mapping({"grid": SMALL})
        assert run.model == name and model.memory_bytes(run, 1) >= model.least_memory_bytes(run) > 0
    assert MODELS["mann"].shared_part(MannRun.from_mapping({"grid": SMALL}), 1, None) is not None
    assert MODELS["kaimal"].shared_part(None, 1, None) is None
    with pytest.raises(ParameterError, match="not one of mann, kaimal"):
        get_model("karman")

