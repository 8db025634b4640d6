"""The Mann stencil does not depend on alpha*eps^(2/3): one ae-free build serves every ae, bit-identically.

A sweep over the IEC class at one wind speed builds it once; a field scales with sqrt(ae).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest
from click.testing import CliRunner

import turbgen.runs.mann as runs_mann
import turbgen.runs.stencil_cache as stencil_cache
from turbgen.cli import cli
from turbgen.store import open_store
from turbgen.sweep.manifest import read_manifest
from turbgen.synthesis.mann_oracle import slab_factor
from turbgen.synthesis.mann_spacetime import mann_box
from turbgen.synthesis.mann_stencil import BoxShape, build_stencil, stencil_key
from turbgen.theory.params import MannParams

BOX = BoxShape(nt=64, dx_m=4.0, nyp=12, nzp=10, dy_m=6.0, dz_m=5.0)
PARAMS = MannParams(ae=0.3, length_scale_m=30.0, gamma=3.2, evo_time_s=20.0)
CLI_GRID = ["--nt", "32", "--dt", "0.5", "--planes", "0,40", "--ny", "4", "--nz", "4", "--dy", "8"]
CLASSES = {"class_a": "A", "class_b": "B", "class_c": "C"}  # the same Mann parameters, three energy levels


def _counting(monkeypatch, module, name: str) -> list:
    calls = []
    original = getattr(module, name)

    def wrapper(*args, **kwargs):
        calls.append(kwargs)
        return original(*args, **kwargs)

    monkeypatch.setattr(module, name, wrapper)
    return calls


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and np.array_equal(a.view(np.uint8), b.view(np.uint8))  # signed zeros included


@pytest.mark.parametrize("ae", [0.3, 0.0123456789, 2.75])
def test_scaled_unit_stencil_is_bit_identical_to_a_direct_build(ae):
    params = PARAMS.with_ae(ae)
    direct = build_stencil(params, BOX)
    unit = build_stencil(PARAMS.with_ae(9.0), BOX, energy="unit")
    assert unit.params.ae == 1.0 and unit.coef.dtype == np.float64 and unit.cell_factor is None
    scaled = unit.scaled(params)
    assert _same_bits(direct.coef, scaled.coef)
    assert _same_bits(direct.inv_tau, scaled.inv_tau)
    assert _same_bits(direct.cell_factor, scaled.cell_factor) and np.array_equal(direct.cell_index, scaled.cell_index)
    part = build_stencil(params, BOX, slabs=(16, 32))  # out-of-core parts: the same numbers
    assert _same_bits(part.coef, direct.coef[:, 16:32])
    unit_part = build_stencil(params, BOX, energy="unit", slabs=(16, 32)).scaled(params)
    assert _same_bits(unit_part.coef, part.coef) and _same_bits(unit_part.inv_tau, part.inv_tau)
    assert _same_bits(slab_factor(part, 20), slab_factor(direct, 20))  # slab 20 is row 4 of the part
    assert direct.scaled(params) is direct  # a scaled stencil serves its own parameters only
    with pytest.raises(ValueError, match="other parameters"):
        direct.scaled(params.with_ae(2 * ae))
    with pytest.raises(ValueError, match="no coefficients"):
        slab_factor(unit, 0)


@pytest.mark.parametrize("evo_time_s", [20.0, None])
def test_a_stencil_computed_on_demand_gives_the_stored_stencils_field(evo_time_s):
    params = MannParams(ae=0.3, length_scale_m=30.0, gamma=3.2, evo_time_s=evo_time_s)
    stored = build_stencil(params, BOX, evolving=False)
    on_demand = build_stencil(params, BOX, storage="on_demand")
    assert on_demand.coef is None and on_demand.slab_range == stored.slab_range == (0, BOX.nk1)
    assert _same_bits(on_demand.cell_factor, stored.cell_factor)
    for i in (0, 1, BOX.nk1 - 1):  # the prior's factor (conditioning, oracle) from either storage
        assert _same_bits(slab_factor(on_demand, i), slab_factor(stored, i))
    reference = mann_box(stored, 6, 5, seed=3)
    for threads in (1, 2):  # batches computed by whichever thread: the same coefficients
        assert _same_bits(mann_box(on_demand, 6, 5, seed=3, threads=threads), reference)
    for bad in ({"slabs": (0, 16)}, {"energy": "unit"}):
        with pytest.raises(ValueError, match="scaled stencil of the whole box"):
            build_stencil(params, BOX, storage="on_demand", **bad)


def test_the_key_ignores_ae_and_nothing_else():
    assert stencil_key(PARAMS, BOX, True) == stencil_key(PARAMS.with_ae(1.7), BOX, True)
    assert stencil_key(PARAMS, BOX, True) != stencil_key(MannParams(0.3, 31.0, 3.2, evo_time_s=20.0), BOX, True)
    assert stencil_key(PARAMS, BOX, True) != stencil_key(PARAMS, BOX, False)
    with pytest.raises(ValueError, match="other parameters"):
        build_stencil(PARAMS, BOX, energy="unit").scaled(MannParams(0.3, 31.0, 3.2, evo_time_s=20.0))


def test_field_scales_with_the_square_root_of_ae():
    a, b = 0.8, 0.05
    field_a = mann_box(build_stencil(PARAMS.with_ae(a), BOX), 8, 8, seed=5, threads=1)
    field_b = mann_box(build_stencil(PARAMS.with_ae(b), BOX), 8, 8, seed=5, threads=1)
    expected = np.sqrt(a / b) * field_b.astype(np.float64)
    scale = np.abs(expected).max()
    assert np.abs(field_a - expected).max() < 1e-5 * scale  # float32 round-off of the same field
    assert field_a.std() > 0.1


def test_disk_cache_serves_every_ae_from_one_build(tmp_path, monkeypatch):
    builds = _counting(monkeypatch, stencil_cache, "build_stencil")
    for ae in (0.3, 0.6, 1.2):
        got = stencil_cache.cached_stencil(PARAMS.with_ae(ae), BOX, tmp_path)
        assert _same_bits(got.coef, build_stencil(PARAMS.with_ae(ae), BOX).coef)
    assert len(builds) == 1 and [p.suffix for p in tmp_path.iterdir()] == [".npy"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporaries left
    entry = next(tmp_path.iterdir())
    entry.write_bytes(entry.read_bytes()[:1000])  # a truncated entry is rebuilt and replaced
    got = stencil_cache.cached_stencil(PARAMS, BOX, tmp_path)
    assert len(builds) == 2 and _same_bits(got.coef, build_stencil(PARAMS, BOX).coef)
    assert _same_bits(got.inv_tau, build_stencil(PARAMS, BOX).inv_tau)


@pytest.fixture()
def in_process_scheduler():
    """A scheduler whose workers are threads of this process, so the counting wrappers see their calls."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster:  # fmt: skip
        yield cluster.scheduler_address


def test_sweep_over_iec_class_at_one_speed_builds_the_stencil_once(tmp_path, monkeypatch, in_process_scheduler):
    presets = tmp_path / "classes.toml"
    presets.write_text("".join(f'[{name}]\nturb_class = "{c}"\nmann = {{ L = 30.0, gamma = 3.2, evo = 20.0 }}\n'
                               for name, c in CLASSES.items()))  # fmt: skip
    builds = _counting(monkeypatch, runs_mann, "build_stencil")  # the sweep's and run_mann's (no stencil cache)
    out = tmp_path / "sweep"
    res = CliRunner().invoke(cli, ["sweep", "--model", "mann", "--presets-file", str(presets),
                                   "--preset", ",".join(CLASSES), "--speeds", "12", "--seeds", "1", *CLI_GRID,
                                   "--scheduler", in_process_scheduler, "--out", str(out)])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert [kwargs.get("energy") for kwargs in builds] == ["unit"]  # one unit stencil, no run built its own
    runs = read_manifest(out)["runs"]
    assert len(runs) == 3 and all(r["status"] == "complete" for r in runs)
    aes = {r["parameters"]["ae"] for r in runs}
    assert len(aes) == 3  # three energy levels from one stencil
    for r in runs:  # each field bit-identical to `turbgen mann` of that run, which builds its own stencil
        single = tmp_path / f"{r['name']}.zarr"
        res = CliRunner().invoke(cli, ["mann", "--presets-file", str(presets), "--preset", r["preset"], "--U", "12",
                                       "--seed", "1", *CLI_GRID, "--out", str(single)])  # fmt: skip
        assert res.exit_code == 0, res.output
        stored, direct = open_store(out / r["path"]), open_store(single)
        for c in "uvw":
            assert np.array_equal(stored.array(c)[:], direct.array(c)[:]), (r["name"], c)
