"""float32 standard normals of one keyed SFC64 stream by numpy's Ziggurat, compiled (numba).

Bit for bit numpy's ``Generator(SFC64(SeedSequence(key))).standard_normal(n, dtype=np.float32)`` (the 256-layer
Ziggurat of Marsaglia & Tsang 2000, one 32-bit word per draw, low half first; tables from r = 3.6541528853610088,
v = 4.92867323399e-3)."""

from __future__ import annotations

import math

import numba
import numpy as np

from turbgen.synthesis.sfc64 import next64, seed_state

_R = 3.6541528853610087963519472518  # right edge of the base layer (Marsaglia & Tsang 2000, n = 256)
_V = 4.92867323399e-3  # area of every layer


def _tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """k_i (uint32), w_i, f_i (float32) of Marsaglia & Tsang (2000), program ``zigset``, with m = 2^23."""
    m, n = 2.0**23, 256
    k, w, f = np.zeros(n), np.zeros(n), np.zeros(n)
    x_prev = x = _R
    q = _V / math.exp(-0.5 * x * x)  # width of the base strip (rectangle plus tail) at height f(r)
    k[0], w[0], w[n - 1] = x / q * m, q / m, x / m
    f[0], f[n - 1] = 1.0, math.exp(-0.5 * x * x)
    for i in range(n - 2, 0, -1):  # x_i: the rectangle under f(x_i) ... f(x_{i+1}) has area v
        x = math.sqrt(-2.0 * math.log(_V / x_prev + math.exp(-0.5 * x_prev * x_prev)))
        k[i + 1], f[i], w[i] = x / x_prev * m, math.exp(-0.5 * x * x), x / m
        x_prev = x
    return np.round(k).astype(np.uint32), w.astype(np.float32), f.astype(np.float32)


KI, WI, FI = _tables()
_RF = np.float32(_R)
_INV_RF = np.float32(1.0 / _R)
_INV_2_24 = np.float32(2.0**-24)
_M32, _M23, _U8, _U9, _U32 = np.uint64(0xFFFFFFFF), np.uint64(0x7FFFFF), np.uint64(8), np.uint64(9), np.uint64(32)
_MLAYER, _ONE, _TWO, _M9, _U41 = np.uint64(0xFF), np.uint64(1), np.uint64(2), np.uint64(0x1FF), np.uint64(41)
# Tables indexed by the 9 low bits of a word (layer i, then the sign bit): k_i twice, then w_i and -w_i.
_KIS = np.concatenate([KI, KI])
_WIS = np.concatenate([WI, -WI])
_MINUS_HALF = np.float64(-0.5)
_TM = -0.5 * ((KI + 2.0**23) / 2 * WI.astype(np.float64)) ** 2  # t at each wedge's middle x_m = (k_i + 2^23) w_i / 2
_EM_LO, _EM_HI = np.exp(_TM) * (1.0 - 2.0**-30), np.exp(_TM) * (1.0 + 2.0**-30)


@numba.njit(nogil=True, cache=True, inline="always")
def _under_density(y, x, i):
    """numpy's wedge test y < exp(t), t = -x^2/2 (float64), mostly without exp: with d = t - t_m, exp(t) = e^t_m e^d
    and 1 + d <= e^d <= 1 / (1 - d) (d < 1), widened by 2^-30 (far beyond rounding), decide 99.7 % of the y."""
    t = _MINUS_HALF * np.float64(x) * np.float64(x)
    d = t - _TM[i]
    return y < _EM_LO[i] * (1.0 + d) or (y * (1.0 - d) < _EM_HI[i] and y < math.exp(t))


@numba.njit(nogil=True, cache=True)
def _next32(a, b, c, w, has, buf):
    """numpy's ``next_uint32`` of SFC64: the low half of a fresh 64-bit output, its high half buffered."""
    if has:
        return buf, a, b, c, w, False, buf
    r, a, b, c, w = next64(a, b, c, w)
    return r & _M32, a, b, c, w, True, r >> _U32


@numba.njit(nogil=True, cache=True)
def _next_float(a, b, c, w, has, buf):
    """numpy's ``next_float``: (u >> 8) 2^-24, in [0, 1)."""
    u, a, b, c, w, has, buf = _next32(a, b, c, w, has, buf)
    return np.float32(u >> _U8) * _INV_2_24, a, b, c, w, has, buf


@numba.njit(nogil=True, cache=True, inline="always")  # inlined (numba IR) in fill_normals: 10 % less time there
def _normal(u, a, b, c, w, has, buf):
    """One normal whose first word is ``u``, drawing further words as needed; returns (x, state...)."""
    while True:
        i = u & _MLAYER
        m = (u >> _U9) & _M23
        x = np.float32(m) * WI[i]
        if (u >> _U8) & _ONE:
            x = -x
        if m < KI[i]:
            return x, a, b, c, w, has, buf
        if i == 0:  # tail beyond r: x = -ln(U1)/r, y = -ln(U2), accept if 2y > x^2 (Marsaglia & Tsang 2000)
            while True:
                f1, a, b, c, w, has, buf = _next_float(a, b, c, w, has, buf)
                xx = -_INV_RF * np.float32(math.log1p(-f1))
                f2, a, b, c, w, has, buf = _next_float(a, b, c, w, has, buf)
                yy = -np.float32(math.log1p(-f2))
                if yy + yy > xx * xx:
                    t = _RF + xx
                    return (-t if (m >> _U8) & _ONE else t), a, b, c, w, has, buf
        else:  # wedge: a uniform height in [f_i, f_{i-1}] under exp(-x^2/2) (compared in float64, as numpy)
            f1, a, b, c, w, has, buf = _next_float(a, b, c, w, has, buf)
            if _under_density(np.float64((FI[i - 1] - FI[i]) * f1 + FI[i]), x, i):
                return x, a, b, c, w, has, buf
        u, a, b, c, w, has, buf = _next32(a, b, c, w, has, buf)


@numba.njit(nogil=True, cache=True)
def fill_normals(words, out):
    """Fill float32 ``out`` (1-D) with the first normals of the stream keyed by uint32 ``words`` (sfc64.key_words)."""
    a, b, c, w = seed_state(words)
    n, i = np.uint64(out.size), np.uint64(0)  # unsigned: stores without the negative-index wrap
    while i + _ONE < n:  # at a pair boundary (no half word buffered)
        # Fast: one 64-bit output per pair of values while both halves fall in their rectangles (97 %).
        # The 9-bit index (layer, sign) reads the signed tables, so x = m w_i carries its sign: the same
        # float32 product as numpy's x = m w_i then x = -x, without the branch.
        r, a, b, c, w = next64(a, b, c, w)
        jl, ml = r & _M9, (r >> _U9) & _M23
        jh, mh = (r >> _U32) & _M9, r >> _U41
        if (ml < _KIS[jl]) & (mh < _KIS[jh]):
            out[i] = np.float32(np.int32(ml)) * _WIS[jl]
            out[i + _ONE] = np.float32(np.int32(mh)) * _WIS[jh]
            i += _TWO
            continue
        # else the general path, exactly numpy's: the low half starts a value, the high half is buffered
        out[i], a, b, c, w, has, buf = _normal(r & _M32, a, b, c, w, True, r >> _U32)
        i += _ONE
        while has and i < n:  # a high half left buffered starts the next value
            out[i], a, b, c, w, has, buf = _normal(buf, a, b, c, w, False, buf)
            i += _ONE
    if i < n:  # an odd last value, from the low half of a fresh output
        r, a, b, c, w = next64(a, b, c, w)
        out[i] = _normal(r & _M32, a, b, c, w, True, r >> _U32)[0]
    return out
