"""Counter-keyed complex Gaussian noise: one independent stream per key -- (seed, snapshot, k1-slab) for
Mann fields, (seed, component, plane, frequency chunk) for Kaimal fields.

The stream of a slab depends only on its key, never on call order, chunking or threads, so a
field is bit-identical however the work is split. Gaussians come from the Box-Muller transform
of SFC64 raw bits in float32 (about 4x faster than ``Generator.standard_normal`` here, and
exact: r = sqrt(-2 ln u1), (re, im) = r (cos 2 pi u2, sin 2 pi u2) are independent N(0, 1)).
"""

from __future__ import annotations

import numpy as np
from numpy.random import SFC64, SeedSequence

_TWO_PI = np.float32(2.0 * np.pi)
_INV_2_24 = np.float32(2.0**-24)
_ANGLE_STEP = _INV_2_24 * _TWO_PI  # float32
_BLOCK = 24576  # 96 KiB float32 temporaries (in L2); 2 blocks per 3 x 128 x 128 slab: ~8 % faster than 8192


def slab_key(seed: int, snapshot: int, slab: int) -> tuple[int, int, int]:
    """The entropy tuple of one stream (documented so other tools can reproduce a field)."""
    return (int(seed), int(snapshot), int(slab))


def complex_normal(seed: int, snapshot: int, slab: int, out: np.ndarray) -> np.ndarray:
    """Fill complex64 ``out`` (C-contiguous, any shape) with standard complex normals of one Mann slab.

    Real and imaginary parts are independent N(0, 1) (so E|n|^2 = 2), drawn from the stream
    keyed by (seed, snapshot, slab); components/rows follow in C order of ``out``.
    """
    return keyed_complex_normal(slab_key(seed, snapshot, slab), out)


def keyed_complex_normal(key: tuple[int, ...], out: np.ndarray) -> np.ndarray:
    """Fill complex64 ``out`` (C-contiguous, any shape) with standard complex normals of the stream ``key``.

    Parameters
    ----------
    key : tuple of int
        Entropy of the stream (``SeedSequence(key)`` seeds an SFC64 generator); any fixed tuple of
        non-negative integers naming the stream, never a call counter.
    out : numpy.ndarray
        complex64, C-contiguous; filled in C order.

    Returns
    -------
    numpy.ndarray
        ``out``, whose real and imaginary parts are independent N(0, 1) (E|n|^2 = 2).
    """
    n = out.size
    # One uint64 per complex value, viewed as 2n uint32: the first n give u1, the last n u2.
    bits = SFC64(SeedSequence(tuple(int(k) for k in key))).random_raw(n).view(np.uint32)
    np.right_shift(bits, 8, out=bits)  # 24-bit integers, exact in float32
    ints = bits.view(np.int32)
    pairs = out.reshape(-1).view(np.float32).reshape(n, 2)
    # The transform runs in blocks of _BLOCK values so its temporaries stay in cache (1.7x faster than
    # whole-array passes); every value goes through the same float32 operations, so the block size
    # never changes a bit.
    radius, angle, cos = (np.empty(min(n, _BLOCK), np.float32) for _ in range(3))
    for j in range(0, n, _BLOCK):
        m = min(_BLOCK, n - j)
        r, a, c = radius[:m], angle[:m], cos[:m]
        np.add(ints[j : j + m], np.float32(1.0), out=r, dtype=np.float32)
        r *= _INV_2_24  # u1 in (0, 1]
        np.multiply(ints[n + j : n + j + m], _ANGLE_STEP, out=a, dtype=np.float32)  # 2 pi u2, u2 in [0, 1)
        np.log(r, out=r)
        r *= np.float32(-2.0)
        np.sqrt(r, out=r)
        np.cos(a, out=c)
        np.sin(a, out=a)
        np.multiply(c, r, out=pairs[j : j + m, 0])
        np.multiply(a, r, out=pairs[j : j + m, 1])
    return out
