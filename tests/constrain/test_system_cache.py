"""The constrained runs' system H C H^T kept in the stencil cache (turbgen.runs.stencil_cache.cached_system): read
by every seed conditioned on the same measurements, the same bits as computing it, a new entry for a new geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from turbgen.runs import constrain
from turbgen.runs.constrain import run_mann_constrained
from turbgen.spec.constraints import point_series_from_mapping
from turbgen.spec.mann import MannRun
from turbgen.store import open_store

GRID = {"nt": 128, "dt_s": 0.5, "x_m": [0.0, 40.0], "ny": 4, "nz": 4, "dy_m": 10.0}


def _mast(y_m: float = 3.0):
    t = np.arange(0.0, 25.0, 0.25)
    u = 1.5 * np.sin(t / 3.0)
    u[20:25] = np.nan
    return point_series_from_mapping({
        "kind": "point-series", "name": "mast", "time_s": list(t), "total_wind": False,
        "sensors": [{"name": "hub", "x_m": 0.0, "y_m": y_m, "z_m": -4.0,
                     "u_m_s": [None if math.isnan(v) else v for v in u], "w_m_s": list(0.4 * np.cos(t / 2.0))},
                    {"name": "gate", "x_m": 40.0, "y_m": -10.0, "z_m": 5.0, "v_m_s": list(0.8 * np.sin(t / 5.0))}],
    }, "mast.json")  # fmt: skip


def _field(path):
    fs = open_store(path)
    return np.stack([np.stack([fs.read_plane(c, p) for p in range(fs.grid.nx)]) for c in "uvw"])


def _entries(cache):
    return sorted(cache.glob("mann-stencil-system-*.npy"))


@pytest.fixture
def counted(monkeypatch):
    """How often the system is computed."""
    calls = []
    real = constrain.cond.stream_covariance

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(constrain.cond, "stream_covariance", counting)
    return calls


@pytest.mark.parametrize("noise", [None, 0.05])
def test_seeds_read_the_system_and_get_the_fields_computed_without_cache(tmp_path, counted, noise):
    cache = tmp_path / "cache"
    for seed in (1, 2):
        run = MannRun.from_mapping({"seed": seed, "grid": GRID})
        run_mann_constrained(run, tmp_path / f"plain{seed}.zarr", [_mast()], noise_m_s=noise, threads=1)
        run_mann_constrained(run, tmp_path / f"cached{seed}.zarr", [_mast()], noise_m_s=noise, threads=1,
                             cache_dir=cache)  # fmt: skip
        np.testing.assert_array_equal(_field(tmp_path / f"cached{seed}.zarr"), _field(tmp_path / f"plain{seed}.zarr"))
        assert (open_store(tmp_path / f"cached{seed}.zarr").attrs["constraints"]
                == open_store(tmp_path / f"plain{seed}.zarr").attrs["constraints"])  # fmt: skip
    assert len(counted) == 3  # both uncached runs, the first cached one; the second seed read the entry
    assert len(_entries(cache)) == 1 and not list(cache.glob(".*"))  # no temporary left


def test_another_geometry_or_energy_is_another_entry_and_a_broken_entry_is_replaced(tmp_path, counted):
    cache = tmp_path / "cache"
    run = MannRun.from_mapping({"seed": 1, "grid": GRID})
    run_mann_constrained(run, tmp_path / "a.zarr", [_mast()], threads=1, cache_dir=cache)
    run_mann_constrained(run, tmp_path / "b.zarr", [_mast(y_m=-3.0)], threads=1, cache_dir=cache)
    run_mann_constrained(MannRun.from_mapping({"seed": 1, "grid": GRID, "ae": 0.05}), tmp_path / "c.zarr", [_mast()],
                         threads=1, cache_dir=cache)  # fmt: skip
    assert len(counted) == 3 and len(_entries(cache)) == 3
    first = _field(tmp_path / "a.zarr")
    for entry in _entries(cache):  # a truncated entry (e.g. a disk that filled up) is computed again
        entry.write_bytes(entry.read_bytes()[:200])
    run_mann_constrained(run, tmp_path / "d.zarr", [_mast()], threads=1, cache_dir=cache)
    assert len(counted) == 4
    np.testing.assert_array_equal(_field(tmp_path / "d.zarr"), first)
    run_mann_constrained(run, tmp_path / "e.zarr", [_mast()], threads=1, cache_dir=cache)
    assert len(counted) == 4  # the replaced entry serves again


def test_a_cache_that_cannot_keep_the_system_warns_and_gives_the_same_system(tmp_path):
    from turbgen.runs.constrain import place, stream_system
    from turbgen.runs.mann import build_mann_stencil

    run = MannRun.from_mapping({"seed": 1, "grid": GRID})
    stencil, placed = build_mann_stencil(run), place(run, [_mast()])
    blocked = tmp_path / "a-file"
    blocked.write_text("not a directory")
    with pytest.warns(RuntimeWarning, match="did not keep the system"):
        cov = stream_system(run, stencil, placed, threads=1, cache_dir=blocked)
    np.testing.assert_array_equal(cov, stream_system(run, stencil, placed, threads=1))
    assert blocked.read_text() == "not a directory"
