"""The writer's compiled float64 sum and sum of squares."""

from __future__ import annotations

import numpy as np
import pytest

from turbgen.store.block_sums import block_sums


@pytest.mark.parametrize("shape", [(0,), (1,), (7,), (8,), (9,), (257, 5, 3)])
def test_block_sums_match_float64_numpy(shape):
    a = np.random.default_rng(4).standard_normal(shape).astype(np.float32) * 3 + 1
    total, squares = block_sums(a)
    d = a.astype(np.float64).reshape(-1)
    # float64 accumulation of n float32 values in another order: differences of a few n * 2^-53 relative at most
    tol = 4 * max(d.size, 1) * 2.0**-53
    assert total == pytest.approx(d.sum(), rel=tol, abs=tol * np.abs(d).sum())
    assert squares == pytest.approx(np.dot(d, d), rel=tol)


def test_block_sums_of_a_strided_block_and_of_non_finite_values():
    a = np.arange(60, dtype=np.float32).reshape(3, 4, 5)[:, ::2, 1:]
    assert block_sums(a) == (float(a.sum(dtype=np.float64)), float((a.astype(np.float64) ** 2).sum()))
    for bad in (np.nan, np.inf, -np.inf):
        b = np.ones(17, np.float32)
        b[13] = bad
        assert not np.isfinite(block_sums(b)[0])


def test_writer_returns_the_sums_of_its_check(tmp_path):
    from turbgen.grid import Grid
    from turbgen.store import create_store

    attrs = {"model": "kaimal", "parameters": {}, "units": {}, "seed": 1, "U_m_s": 10.0, "hub_height_m": 90.0}
    grid = Grid(nt=8, dt_s=0.5, x_m=(0.0,), ny=3, nz=2, dy_m=5.0, dz_m=4.0)
    block = np.random.default_rng(5).standard_normal((8, 3, 2)).astype(np.float32)
    with create_store(tmp_path / "s.zarr", grid, attrs) as w:
        assert w.write("u", 0, block) == block_sums(block)[0]
        assert w.write("v", 0, block, squares=True) == block_sums(block)
        with pytest.raises(ValueError, match="NaN or inf"):
            w.write("w", 0, np.full((8, 3, 2), np.nan, np.float32))
        w.write("w", 0, block)
