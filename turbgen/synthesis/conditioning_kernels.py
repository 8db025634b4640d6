"""Compiled loops of the Mann conditioning (turbgen.synthesis.conditioning): key amplitudes per slab and the
pair sums L_i[a, b] = sum_(k in a, k' in b) P_k conj(P_k') G(y_k - y_k', z_k - z_k')."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(nogil=True, cache=True)
def key_amplitudes(term_key, term_shift, term_weight, slabs, nt, out):
    """out[b, k] = P_k(slabs[b]) (complex128), the terms' weights times their time-shift phases summed per key."""
    out[:] = 0.0
    for b in range(len(slabs)):
        i = slabs[b]
        for t in range(len(term_key)):
            if term_key[t] < 0:
                continue
            phase = 2.0 * np.pi * ((i * term_shift[t]) % nt) / nt
            out[b, term_key[t]] += term_weight[t] * (np.cos(phase) + 1j * np.sin(phase))


@numba.njit(nogil=True, cache=True)
def pair_sums(amp, bounds, key_dir, key_iy, key_iz, dir_pair, pair_class, cls, lag, out):
    """Add to L[a, b] (``out`` (M, M)) of one slab the stream pairs of lag class ``cls``.

    ``lag`` holds G(dy, dz) at [dy + e_y - 1, dz + e_z - 1]; the pairs a <= b are summed, the others are their
    Hermitian conjugates."""
    cy, cz = (lag.shape[1] - 1) // 2, (lag.shape[2] - 1) // 2
    m = len(bounds) - 1
    for a in range(m):
        for b in range(a, m):
            if pair_class[a, b] != cls:
                continue
            acc = 0.0j
            for k in range(bounds[a], bounds[a + 1]):
                yk, zk, dk = key_iy[k] + cy, key_iz[k] + cz, key_dir[k]
                part = 0.0j
                for k2 in range(bounds[b], bounds[b + 1]):
                    part += np.conj(amp[k2]) * lag[dir_pair[dk, key_dir[k2]], yk - key_iy[k2], zk - key_iz[k2]]
                acc += amp[k] * part
            out[a, b] += acc
            if b != a:
                out[b, a] += np.conj(acc)


@numba.njit(nogil=True, cache=True)
def chain_correction(f, rho, step, phi, rows, out):
    """out[r] = Phi sum_q rho_(rows[r] q) f_q per (k2, k3) point, sums in float64.

    Forwards h_p = rho h_(p-1) + f_p and backwards k_p = rho k_(p+1) + f_p; h + k - f counts f_p once."""
    n_planes, n_values = f.shape[0], f.shape[2]
    block = 512  # values (256 points)
    fwd = np.empty((n_planes, 3, block))
    bwd = np.empty((n_planes, 3, block))
    rb = np.empty((max(n_planes - 1, 1), block))
    pb = np.empty((3, 3, block))
    total = np.empty((3, block))
    for v0 in range(0, n_values, block):
        nv = min(block, n_values - v0)
        for p in range(n_planes - 1):
            _expand(rho[step[p]], v0, nv, rb[p])
        for c in range(3):
            for d in range(3):
                _expand(phi[c, d], v0, nv, pb[c, d])
            fwd[0, c, :nv] = f[0, c, v0 : v0 + nv]
            bwd[n_planes - 1, c, :nv] = f[n_planes - 1, c, v0 : v0 + nv]
        for p in range(1, n_planes):
            for c in range(3):
                _step(rb[p - 1], fwd[p - 1, c], f[p, c, v0 : v0 + nv], fwd[p, c])
        for p in range(n_planes - 2, -1, -1):
            for c in range(3):
                _step(rb[p], bwd[p + 1, c], f[p, c, v0 : v0 + nv], bwd[p, c])
        for r in range(len(rows)):
            p = rows[r]
            for d in range(3):
                a, b, g, t = fwd[p, d], bwd[p, d], f[p, d, v0 : v0 + nv], total[d]
                for v in range(nv):
                    t[v] = a[v] + b[v] - g[v]
            s0, s1, s2 = total[0], total[1], total[2]
            for c in range(3):
                o, q0, q1, q2 = out[r, c, v0 : v0 + nv], pb[c, 0], pb[c, 1], pb[c, 2]
                for v in range(nv):
                    o[v] = q0[v] * s0[v] + q1[v] * s1[v] + q2[v] * s2[v]


@numba.njit(nogil=True, cache=True, inline="always")
def _expand(per_point, v0, nv, out):
    """out[v] = per_point[(v0 + v) // 2]: one value per (real, imaginary) pair."""
    for v in range(nv):
        out[v] = per_point[(v0 + v) >> 1]


@numba.njit(nogil=True, cache=True, inline="always")
def _step(rho, previous, fresh, out):
    """out = rho previous + fresh over the block."""
    for v in range(len(fresh)):
        out[v] = rho[v] * previous[v] + fresh[v]


@numba.njit(nogil=True, cache=True)
def scatter_terms(spec_w, term_stream, grid_index, term_shift, term_weight, slabs, nt, grid):
    """grid[b, grid_index[t]] += W_a(i) w_t exp(-2 pi i i s_t / nt) for the slabs i = slabs[b] (``spec_w`` (M, B) the
    streams' weight spectra on those slabs, ``grid`` (B, planes 3 nyp nzp) complex64, zeroed by the caller); the
    phases once per slab and distinct shift."""
    phases = np.empty(term_shift.max() + 1, np.complex128)
    for b in range(len(slabs)):
        i = slabs[b]
        for shift in range(len(phases)):
            phase = -2.0 * np.pi * ((i * shift) % nt) / nt
            phases[shift] = np.cos(phase) + 1j * np.sin(phase)
        for t in range(len(term_stream)):
            grid[b, grid_index[t]] += spec_w[term_stream[t], b] * term_weight[t] * phases[term_shift[t]]


@numba.njit(nogil=True, cache=True)
def direction_products(factor, directions, first, second, psi):
    """psi[p, j] = 2 (C^T n_first[p]) . (C^T n_second[p]) = n^T Phi n' at every (k2, k3) point j of a slab:
    ``factor`` C (3, 3, J) (prior_spectrum: Phi = 2 C C^T), ``directions`` (D, 3), ``psi`` (pairs, J) float64. Loops
    run along j innermost."""
    n_dir, n_points = directions.shape[0], factor.shape[2]
    along = np.zeros((n_dir, 3, n_points))
    for d in range(n_dir):
        for k in range(3):
            for c in range(3):
                w = directions[d, c]
                if w != 0.0:
                    for j in range(n_points):
                        along[d, k, j] += w * factor[c, k, j]
    psi[:] = 0.0
    for p in range(len(first)):
        for k in range(3):
            for j in range(n_points):
                psi[p, j] += 2.0 * along[first[p], k, j] * along[second[p], k, j]


@numba.njit(nogil=True, cache=True)
def lag_input(psi, rho, x):
    """x[p, j] = rho[j] psi[p, j]: ``psi`` (B, J) the basis inputs, ``rho`` (J,) the lag's factors, ``x`` (B, J)."""
    for p in range(psi.shape[0]):
        for j in range(psi.shape[1]):
            x[p, j] = psi[p, j] * rho[j]


@numba.njit(nogil=True, cache=True)
def lag_factors(lag, inv_tau, rho):
    """rho[j] = exp(-lag inv_tau[j]) [1/s x s]."""
    for j in range(len(inv_tau)):
        rho[j] = np.exp(-lag * inv_tau[j])


@numba.njit(nogil=True, cache=True)
def times_into(a, b):
    """a[j] *= b[j]."""
    for j in range(len(a)):
        a[j] *= b[j]


@numba.njit(nogil=True, cache=True)
def lag_window(z, n_even, parity, nzp, out):
    """The lag covariances G_b(dy, dz) = conj R_b(dy, dz) into ``out`` from their DFTs R_b in ``z``.

    With ``parity``, the odd components were transformed along y by a DST-I on rows 1 .. nyp/2 - 1:
    R(+-dy) = z[0] + (-1)^dy z[nyp/2] -+ i Y(dy); the even ones by a DCT-I, R(dy) = z[dy]."""
    n_basis, ny_w, nz_w = out.shape
    cy, cz = (ny_w - 1) // 2, (nz_w - 1) // 2
    nyp = 2 * (z.shape[1] - 1) if parity else z.shape[1]
    half_z = nzp // 2
    kept = min(cz + 1, half_z + 1)
    plus = np.empty(kept, np.complex128)  # R(dy, col) and R(-dy, col) of one window row
    minus = np.empty(kept, np.complex128)
    for b in range(n_basis):
        for i in range(ny_w):
            dy = (i - cy) % nyp
            _basis_row(z, b, dy, n_even, parity, nyp, plus)
            _basis_row(z, b, (nyp - dy) % nyp, n_even, parity, nyp, minus)
            col = (-cz) % nzp
            for j in range(nz_w):  # G(d) = conj R(d) = R(-d): R's stored half has the columns <= nzp / 2
                out[b, i, j] = np.conj(plus[col]) if col <= half_z else minus[nzp - col]
                col += 1
                if col == nzp:
                    col = 0


@numba.njit(nogil=True, cache=True, inline="always")
def _basis_row(z, b, dy, n_even, parity, nyp, out):
    """out[col] = R_b(dy, col) for the columns of ``out`` (see lag_window)."""
    if not parity or b < n_even:
        row = dy if not parity or dy <= nyp // 2 else nyp - dy
        for col in range(len(out)):
            out[col] = z[b, row, col]
        return
    half = nyp // 2
    row = dy if dy <= half else nyp - dy
    sign = 1.0 - 2.0 * (row % 2)
    turn = 0.0 if row == 0 or row == half else (1.0 if dy <= half else -1.0)  # -+ i Y
    for col in range(len(out)):
        y = z[b, row, col]
        out[col] = z[b, 0, col] + sign * z[b, half, col] + turn * (y.imag - 1j * y.real)


@numba.njit(nogil=True, cache=True)
def combine_pairs(window, weights, out):
    """out[p] = sum_b weights[p, b] window[b]: the direction pairs' lag covariances from the basis inputs' (``window``
    (B, ...) and ``out`` (P, ...) as flat float64 views)."""
    n_pairs, n_basis = weights.shape
    for p in range(n_pairs):
        row = out[p]
        row[:] = 0.0
        for b in range(n_basis):
            w = weights[p, b]
            if w != 0.0:
                src = window[b]
                for n in range(len(row)):
                    row[n] += w * src[n]


@numba.njit(nogil=True, cache=True)
def slab_components(coef, j, k1, k2, k3sq, cell_row, cell_col, cell_factor, out):
    """Phi = 2 C C^T's six components (COMPONENT_PAIRS order) of one slab on rows 0 .. R - 1, from the compact
    coefficients (the axis cells' factors replace them there): mann_oracle.slab_factor's operations, point by point."""
    nyp, half = len(k2), coef.shape[2] - 1
    c = np.empty((3, 3))
    for r in range(out.shape[1]):
        src, sign = (r, 1.0) if r <= half else (nyp - r, -1.0)
        kk2 = k2[r]
        q = k1 * k1 + kk2 * kk2
        for col in range(out.shape[2]):
            a = np.float64(coef[0, j, src, col])
            p = np.float64(coef[1, j, src, col])
            z1 = np.float64(coef[2, j, src, col])
            z2 = sign * np.float64(coef[3, j, src, col])
            den = a * (q + k3sq[col])
            w = (a * a * q + p * p) / den if den != 0.0 else 0.0
            c[0, 0], c[0, 1], c[0, 2] = z1 * kk2, p - z1 * k1, -a * kk2
            c[1, 0], c[1, 1], c[1, 2] = -p + z2 * kk2, -z2 * k1, a * k1
            c[2, 0], c[2, 1], c[2, 2] = w * kk2, -w * k1, 0.0
            _phi_of(c, out, r, col)
    for n in range(len(cell_row)):
        if cell_row[n] < out.shape[1]:
            _phi_of(cell_factor[n], out, cell_row[n], cell_col[n])


@numba.njit(nogil=True, cache=True, inline="always")
def _phi_of(c, out, r, col):
    """out[:, r, col] = the six components of 2 c c^T."""
    out[0, r, col] = 2.0 * (c[0, 0] * c[0, 0] + c[0, 1] * c[0, 1] + c[0, 2] * c[0, 2])
    out[1, r, col] = 2.0 * (c[1, 0] * c[1, 0] + c[1, 1] * c[1, 1] + c[1, 2] * c[1, 2])
    out[2, r, col] = 2.0 * (c[2, 0] * c[2, 0] + c[2, 1] * c[2, 1] + c[2, 2] * c[2, 2])
    out[3, r, col] = 2.0 * (c[0, 0] * c[2, 0] + c[0, 1] * c[2, 1] + c[0, 2] * c[2, 2])
    out[4, r, col] = 2.0 * (c[0, 0] * c[1, 0] + c[0, 1] * c[1, 1] + c[0, 2] * c[1, 2])
    out[5, r, col] = 2.0 * (c[1, 0] * c[2, 0] + c[1, 1] * c[2, 1] + c[1, 2] * c[2, 2])
