"""Counter-keyed complex Gaussian noise: one stream per key, (seed, snapshot, k1-slab) for Mann fields, (seed,
component, plane, frequency chunk) for Kaimal fields; never dependent on call order, chunking or threads.

The values equal numpy.random.Generator(SFC64(SeedSequence(key))).standard_normal(2 n, dtype=float32) viewed as
complex64, from compiled kernels (turbgen.synthesis.sfc64, ziggurat_normals) tested bit for bit."""

from __future__ import annotations

import numpy as np

from turbgen.synthesis.sfc64 import key_words
from turbgen.synthesis.ziggurat_normals import fill_normals


def slab_key(seed: int, snapshot: int, slab: int) -> tuple[int, int, int]:
    """The entropy tuple of one stream (documented so other tools can reproduce a field)."""
    return (int(seed), int(snapshot), int(slab))


def complex_normal(seed: int, snapshot: int, slab: int, out: np.ndarray) -> np.ndarray:
    """Fill complex64 ``out`` (C-contiguous, any shape) with the standard complex normals of Mann slab
    (seed, snapshot, slab) (:func:`keyed_complex_normal`)."""
    return keyed_complex_normal(slab_key(seed, snapshot, slab), out)


def keyed_complex_normal(key: tuple[int, ...], out: np.ndarray) -> np.ndarray:
    """Fill complex64 ``out`` (C-contiguous) in C order with stream ``key``'s complex normals (E|n|^2 = 2)."""
    if out.dtype != np.complex64 or not out.flags.c_contiguous:
        layout = "C-contiguous" if out.flags.c_contiguous else "non-contiguous"
        raise ValueError(f"noise output must be a C-contiguous complex64 array, got a {layout} {out.dtype} one")
    fill_normals(key_words(tuple(key)), out.reshape(-1).view(np.float32))
    return out
