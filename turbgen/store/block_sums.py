"""The float64 sum and sum of squares of a float32 block in one compiled pass (the writer's finiteness check).

numpy's ``block.sum(dtype=np.float64)`` casts chunk by chunk and the sum of squares was a second pass
(``np.einsum(..., dtype=np.float64)``; ``np.dot`` of float32: float32 accumulation and OpenBLAS threads spinning
beside the generator's). Eight float64 accumulators per sum keep
the loop at the speed of memory without reassociating anything behind our back (no fastmath): the result
depends only on the block's values and their order, never on threads or chunking.
"""

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
    """Sum and sum of squares of ``block``'s values, accumulated in float64.

    Parameters
    ----------
    block : numpy.ndarray
        float32 values of any shape (a non-contiguous block is copied first).

    Returns
    -------
    tuple of float
        (sum [unit of the values], sum of squares [unit^2]); not finite if any value is NaN or inf.
    """
    flat = np.ascontiguousarray(block, dtype=np.float32).reshape(-1)
    total, squares = _sums(flat)
    return float(total), float(squares)
