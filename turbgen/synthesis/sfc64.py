"""numpy's SFC64 generator seeded by ``SeedSequence(key)``, compiled (numba) so a stream is cheap to set up.

:func:`seed_state` gives exactly numpy's state (O'Neill's SeedSequence of the key's 32-bit words, least
significant first) and :func:`next64` is ``random_raw`` (Doty-Humphrey's Small Fast Chaotic generator, 2013)."""

from __future__ import annotations

import numba
import numpy as np

_U1, _U3, _U11, _U16, _U24, _U32, _U40 = (np.uint64(s) for s in (1, 3, 11, 16, 24, 32, 40))
_M32 = np.uint64(0xFFFFFFFF)
# numpy.random.bit_generator SeedSequence constants (pool size 4, XSHIFT = 16)
_INIT_A, _MULT_A = np.uint64(0x43B0D7E5), np.uint64(0x931E8875)
_INIT_B, _MULT_B = np.uint64(0x8B51F9DD), np.uint64(0x58F38DED)
_MIX_L, _MIX_R = np.uint64(0xCA01F9DD), np.uint64(0x4973F715)


def key_words(key: tuple[int, ...]) -> np.ndarray:
    """The uint32 entropy words of ``key``, as ``SeedSequence(key).entropy`` is split by numpy."""
    words = []
    for k in key:
        k = int(k)
        if k < 0:
            raise ValueError(f"stream key entries must be non-negative integers, got {k}")
        words.append(k & 0xFFFFFFFF)
        k >>= 32
        while k:
            words.append(k & 0xFFFFFFFF)
            k >>= 32
    return np.array(words, dtype=np.uint32)


@numba.njit(nogil=True, cache=True)
def _hashmix(value, hash_const):
    """One step of SeedSequence's hash (uint32 arithmetic in uint64 registers); returns (value, hash_const)."""
    value = (value ^ hash_const) & _M32
    hash_const = (hash_const * _MULT_A) & _M32
    value = (value * hash_const) & _M32
    return value ^ (value >> _U16), hash_const


@numba.njit(nogil=True, cache=True)
def _mix(x, y):
    r = (_MIX_L * x - _MIX_R * y) & _M32
    return r ^ (r >> _U16)


@numba.njit(nogil=True, cache=True)
def next64(a, b, c, w):
    """One SFC64 step: returns (output, a, b, c, w), all uint64."""
    tmp = a + b + w
    return tmp, b ^ (b >> _U11), c + (c << _U3), ((c << _U24) | (c >> _U40)) + tmp, w + _U1


@numba.njit(nogil=True, cache=True)
def seed_state(words):
    """SFC64 state (a, b, c, w) of ``SFC64(SeedSequence(key))`` from the key's uint32 ``words``."""
    pool = np.zeros(4, np.uint64)
    h = _INIT_A
    for i in range(4):
        v = np.uint64(words[i]) if i < words.size else np.uint64(0)
        pool[i], h = _hashmix(v, h)
    for i_src in range(4):
        for i_dst in range(4):
            if i_src != i_dst:
                v, h = _hashmix(pool[i_src], h)
                pool[i_dst] = _mix(pool[i_dst], v)
    for i_src in range(4, words.size):
        for i_dst in range(4):
            v, h = _hashmix(np.uint64(words[i_src]), h)
            pool[i_dst] = _mix(pool[i_dst], v)
    # generate_state(3, uint64): six uint32 words from the cycled pool, paired little-endian
    s = np.zeros(3, np.uint64)
    h = _INIT_B
    for i in range(6):
        v = (pool[i % 4] ^ h) & _M32
        h = (h * _MULT_B) & _M32
        v = (v * h) & _M32
        v ^= v >> _U16
        s[i // 2] |= v << (_U32 * np.uint64(i % 2))
    a, b, c, w = s[0], s[1], s[2], _U1
    for _ in range(12):
        _, a, b, c, w = next64(a, b, c, w)
    return a, b, c, w


@numba.njit(nogil=True, cache=True)
def raw(words, out):
    """Fill uint64 ``out`` with the first ``out.size`` outputs of the stream (numpy's ``random_raw``)."""
    a, b, c, w = seed_state(words)
    for i in range(out.size):
        out[i], a, b, c, w = next64(a, b, c, w)
    return out
