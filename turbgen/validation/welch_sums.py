"""Compiled inner loops of one validator task (``span_sums``): point moments, windowed segments, and the
per-frequency sums of a segment's spectra, each one pass over the data.

The complex64 spectra (nf, ny, nz) are read as float32 (nf, ny, 2 nz), re and im interleaved: for rows a, b,
sum_k a[k] b[k] = Re sum_z conj(x_z) y_z, and with t = -i y, sum_k a[k] t[k] = Im sum_z conj(x_z) y_z, so every
cross-product is an element-wise product of contiguous rows, summed in float32 over y, then in float64 over z."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(nogil=True, cache=True)
def point_moments(d, mask_index, block):
    """Per-point float64 sums over time of a float32 span (t, ny, nz): (sum [m/s], sum of squares [m^2 s^-2]), the
    (t // block, ny, nz) sums over blocks of ``block`` steps, the (t,) mean over the flat points ``mask_index``."""
    nt, ny, nz = d.shape
    npt = ny * nz
    flat = d.reshape(nt, npt)
    nblk = nt // block
    blocks = np.zeros((nblk, npt))
    s = np.zeros(npt)  # the tail after the last whole block
    s2 = np.zeros(npt)
    mean = np.zeros(nt)
    n_mask = max(mask_index.size, 1)
    for t in range(nt):
        row = flat[t]
        acc = blocks[t // block] if t < nblk * block else s
        for p in range(npt):
            v = np.float64(row[p])
            acc[p] += v
            s2[p] += v * v
        a0 = 0.0  # four partial sums: independent additions
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        n4 = mask_index.size - mask_index.size % 4
        for i in range(0, n4, 4):
            a0 += row[mask_index[i]]
            a1 += row[mask_index[i + 1]]
            a2 += row[mask_index[i + 2]]
            a3 += row[mask_index[i + 3]]
        for i in range(n4, mask_index.size):
            a0 += row[mask_index[i]]
        mean[t] = (a0 + a1 + a2 + a3) / n_mask
    for k in range(nblk):
        for p in range(npt):
            s[p] += blocks[k, p]
    return s.reshape(ny, nz), s2.reshape(ny, nz), blocks.reshape(nblk, ny, nz), mean


@numba.njit(nogil=True, cache=True)
def window_segment(d, start, window, mean, out):
    """out[:, :ny] = (d[start : start + n] - mean) x window, float32 (n = window.size; ``mean`` (ny, nz)
    float32; ``out`` (n, ny_out >= ny, nz): rows ny and after are left as they are)."""
    n = window.size
    _, ny, nz = d.shape
    npt = ny * nz
    src = d.reshape(d.shape[0], npt)
    dst = out.reshape(n, out.shape[1] * nz)  # the first npt elements of a time step are its rows < ny
    m = mean.reshape(npt)
    for t in range(n):
        row = src[start + t]
        w = window[t]
        o = dst[t]
        for p in range(npt):
            o[p] = (row[p] - m[p]) * w


@numba.njit(nogil=True, cache=True)
def spectrum_sums(xv, ny, sep_a, sep_b, total, part_a, part_b, cross):
    """Add one segment's spectral sums of one component (float32 view (nf, ny_x, 2 nz)) into float64 arrays, per
    frequency: ``total`` sum of |X|^2; per separation ``part_a``, ``part_b`` the pairs' |X|^2 sums and ``cross`` Re / Im
    of sum conj(X(y, z)) X(y + a, z + b)."""
    nf, _, nz2 = xv.shape
    nz = nz2 // 2
    ns = sep_a.size
    rot = np.empty((ny, nz2), np.float32)  # -i X: (Im, -Re)
    col = np.zeros((ny + 1, nz2), np.float32)  # col[y] = sum over rows < y of the squares, per element
    acc_re = np.empty(nz2, np.float32)
    acc_im = np.empty(nz2, np.float32)
    for f in range(nf):
        x = xv[f]
        for y in range(ny):
            xr = x[y]
            ry = rot[y]
            for z in range(nz):
                ry[2 * z] = xr[2 * z + 1]
                ry[2 * z + 1] = -xr[2 * z]
            c0 = col[y]
            c1 = col[y + 1]
            for j in range(nz2):
                c1[j] = c0[j] + xr[j] * xr[j]
        tot = 0.0
        last = col[ny]
        for j in range(nz2):
            tot += last[j]
        total[f] += tot
        for k in range(ns):
            a = sep_a[k]
            b = sep_b[k]
            m = 2 * (nz - b)
            first = col[ny - a, :m]  # rows y < ny - a, columns z < nz - b
            hi = col[ny, 2 * b :]  # rows y >= a, columns z >= b
            lo = col[a, 2 * b :]
            pa = 0.0
            pb = 0.0
            for j in range(m):
                pa += first[j]
                pb += hi[j] - lo[j]
            part_a[k, f] += pa
            part_b[k, f] += pb
            are = acc_re[:m]  # slices: non-negative indices, so the loops below vectorise
            aim = acc_im[:m]
            are[:] = 0.0
            aim[:] = 0.0
            for y in range(ny - a):
                p = x[y, :m]
                q = x[y + a, 2 * b :]
                r = rot[y + a, 2 * b :]
                for j in range(m):
                    are[j] += p[j] * q[j]
                    aim[j] += p[j] * r[j]
            sr = 0.0
            si = 0.0
            for j in range(m):
                sr += are[j]
                si += aim[j]
            cross[k, f, 0] += sr
            cross[k, f, 1] += si


@numba.njit(nogil=True, cache=True)
def cross_sum(xv, yv, ny, out):
    """Add sum over the plane (rows y < ny) of conj(X) Y per frequency to ``out`` (nf, 2) float64 (re, im);
    xv, yv float32 views (nf, ny_x >= ny, 2 nz) of two components' spectra."""
    nf, _, nz2 = xv.shape
    acc_re = np.empty(nz2, np.float32)
    acc_im = np.empty(nz2 // 2, np.float32)
    for f in range(nf):
        acc_re[:] = 0.0
        acc_im[:] = 0.0
        for y in range(ny):
            p = xv[f, y]
            q = yv[f, y]
            for j in range(nz2):
                acc_re[j] += p[j] * q[j]
            for z in range(nz2 // 2):
                acc_im[z] += p[2 * z] * q[2 * z + 1] - p[2 * z + 1] * q[2 * z]
        sr = 0.0
        si = 0.0
        for j in range(nz2):
            sr += acc_re[j]
        for z in range(nz2 // 2):
            si += acc_im[z]
        out[f, 0] += sr
        out[f, 1] += si
