"""The float64 sum and sum of squares of a float32 block in one compiled pass (the writer's finiteness check).

Eight accumulators per sum, no fastmath: the result depends only on the block's values and order, never on threads."""

from __future__ import annotations

import numba
import numpy as np

_LANES = 8


@numba.njit(nogil=True, cache=True)
def _sums(flat):
    s = np.zeros(_LANES)
    q = np.zeros(_LANES)
    n = flat.size
    head = n - n % _LANES
    for i in range(0, head, _LANES):
        for j in range(_LANES):
            v = np.float64(flat[i + j])
            s[j] += v
            q[j] += v * v
    total, squares = 0.0, 0.0
    for j in range(_LANES):
        total += s[j]
        squares += q[j]
    for i in range(head, n):
        v = np.float64(flat[i])
        total += v
        squares += v * v
    return total, squares


def block_sums(block: np.ndarray) -> tuple[float, float]:
    """(sum, sum of squares) of a float32 ``block``'s values, accumulated in float64; not finite for NaN or inf."""
    total, squares = _sums(np.ascontiguousarray(block, dtype=np.float32).reshape(-1))
    return float(total), float(squares)
