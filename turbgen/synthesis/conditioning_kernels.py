"""Compiled loops of the Mann conditioning (turbgen.synthesis.conditioning): the streams' node amplitudes per slab
and the pair sums of the stream covariance from the lag covariances of the prior.

A *key* groups the terms of one stream on one (y, z) node along one direction n (a lidar beam's line of sight, or a
component's unit vector). On slab i its amplitude is P_k(i) = sum_(t in k) a_t exp(2 pi i i s_t / nt) (a_t the
term's weight along n), and the stream covariance of the slab is

    L_i[a, b] = sum_(k in a, k' in b) P_k conj(P_k') G_i^(n_k n_k')_(p_a p_b)(y_k - y_k', z_k - z_k'),

with G the lag covariance along the two directions between the two planes (the inverse 2-D DFT of
rho_pq n_k^T Phi_i n_k', given as the forward real DFT R of that real array: G(d) = conj R(d) for d_z in
[0, nzp/2], G(d) = R(-d) otherwise).
"""

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
    """Add to L[a, b] (out, (M, M) complex128) of one slab the stream pairs of lag class ``cls``, from the key
    amplitudes ``amp`` (K,), keys sorted by stream (stream a holds keys bounds[a] .. bounds[a + 1]), and that class's
    real DFTs ``lag`` (direction pairs, nyp, nzp // 2 + 1; read at |dz| < the keys' extent in z only); ``dir_pair``
    (D, D) the index of a direction pair, ``pair_class`` (M, M) the lag class of a stream pair. The pairs a <= b are
    summed, the others are their Hermitian conjugates."""
    nyp, nzp = lag.shape[1], 2 * (lag.shape[2] - 1)
    half = nzp // 2
    m = len(bounds) - 1
    for a in range(m):
        for b in range(a, m):
            if pair_class[a, b] != cls:
                continue
            acc = 0.0j
            for k in range(bounds[a], bounds[a + 1]):
                pk = amp[k]
                yk, zk, dk = key_iy[k], key_iz[k], key_dir[k]
                part = 0.0j
                for k2 in range(bounds[b], bounds[b + 1]):
                    g = lag[dir_pair[dk, key_dir[k2]]]
                    dy = yk - key_iy[k2]
                    dz = zk - key_iz[k2]
                    if dy < 0:
                        dy += nyp
                    if dz < 0:
                        dz += nzp
                    if dz <= half:
                        v = np.conj(g[dy, dz])
                    else:
                        v = g[(nyp - dy) % nyp, nzp - dz]
                    part += np.conj(amp[k2]) * v
                acc += pk * part
            out[a, b] += acc
            if b != a:
                out[b, a] += np.conj(acc)


@numba.njit(nogil=True, cache=True)
def chain_correction(f, rho, phi, rows, out):
    """out[r] = Phi sum_q rho_(rows[r] q) f_q per (k2, k3) point: ``f`` (P, 3, 2 J) float64 the planes' complex
    spectra in time order as (real, imaginary) pairs, ``rho`` (P - 1, J) the Ornstein-Uhlenbeck factors between
    neighbours (their products are the factors between any two planes), ``phi`` (3, 3, J) real symmetric, ``out``
    (len(rows), 3, 2 J) float64 pairs.

    The sum runs forwards h_p = rho h_(p-1) + f_p and backwards k_p = rho k_(p+1) + f_p; h + k - f counts f_p once.
    Real arithmetic (rho and Phi are real), in blocks of points whose planes stay in cache through the passes, with
    rho and Phi repeated per (real, imaginary) value so the innermost loops run over contiguous values."""
    n_planes, n_values = f.shape[0], f.shape[2]
    block = 512  # values (256 points)
    fwd = np.empty((n_planes, 3, block))
    bwd = np.empty((n_planes, 3, block))
    rb = np.empty((max(n_planes - 1, 1), block))
    pb = np.empty((3, 3, block))
    s = np.empty((3, block))
    for v0 in range(0, n_values, block):
        nv = min(block, n_values - v0)
        for p in range(n_planes - 1):
            for v in range(nv):
                rb[p, v] = rho[p, (v0 + v) >> 1]
        for c in range(3):
            for d in range(3):
                for v in range(nv):
                    pb[c, d, v] = phi[c, d, (v0 + v) >> 1]
            for v in range(nv):
                fwd[0, c, v] = f[0, c, v0 + v]
                bwd[n_planes - 1, c, v] = f[n_planes - 1, c, v0 + v]
        for p in range(1, n_planes):
            for c in range(3):
                for v in range(nv):
                    fwd[p, c, v] = rb[p - 1, v] * fwd[p - 1, c, v] + f[p, c, v0 + v]
        for p in range(n_planes - 2, -1, -1):
            for c in range(3):
                for v in range(nv):
                    bwd[p, c, v] = rb[p, v] * bwd[p + 1, c, v] + f[p, c, v0 + v]
        for r in range(len(rows)):
            p = rows[r]
            for d in range(3):
                for v in range(nv):
                    s[d, v] = fwd[p, d, v] + bwd[p, d, v] - f[p, d, v0 + v]
            for c in range(3):
                for v in range(nv):
                    out[r, c, v0 + v] = pb[c, 0, v] * s[0, v] + pb[c, 1, v] * s[1, v] + pb[c, 2, v] * s[2, v]


@numba.njit(nogil=True, cache=True)
def scatter_terms(spec_w, term_stream, grid_index, term_shift, term_weight, slabs, nt, grid):
    """grid[b, grid_index[t]] += W_a(i) w_t exp(-2 pi i i s_t / nt) for the slabs i = slabs[b] (``spec_w`` (M, B) the
    streams' weight spectra on those slabs, ``grid`` (B, planes 3 nyp nzp) complex128, zeroed by the caller); the
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
def lag_input(psi, lag, inv_tau, x):
    """x[p, j] = exp(-lag inv_tau[j]) psi[p, j]: ``psi`` (pairs, J) (direction_products), ``lag`` [s], ``inv_tau``
    (J,) 1/tau_e [1/s] (empty: frozen turbulence, factor 1), ``x`` (pairs, J) float64."""
    n_points = psi.shape[1]
    if len(inv_tau) == 0:
        x[:] = psi
        return
    rho = np.empty(n_points)
    for j in range(n_points):
        rho[j] = np.exp(-lag * inv_tau[j])
    for p in range(psi.shape[0]):
        for j in range(n_points):
            x[p, j] = psi[p, j] * rho[j]


@numba.njit(nogil=True, cache=True)
def combine_pairs(z, weights, n_even, parity, ext_y, keep_z, out):
    """The direction pairs' lag DFTs R^(n n') = sum_b weights[p, b] R_b (``out`` (P, nyp, nzp // 2 + 1) complex128,
    rows |dy| < ext_y and columns < keep_z only: what pair_sums reads) from the basis DFTs in ``z`` (B, rows,
    nzp // 2 + 1).

    Without ``parity``, z holds R_b on every row (rows = nyp). With ``parity`` (nyp even, rows = nyp / 2 + 1), the
    basis is Phi's components ordered even in k2 first (``n_even`` of them), and z holds them transformed along z
    and then along y by a DCT-I (even: R(dy) = R(-dy) = z[dy]) or, for the odd ones, a DST-I on rows 1 .. nyp/2 - 1
    (Y(dy) = z[dy]) with rows 0 and nyp/2 untouched: R(+-dy) = z[0] + (-1)^dy z[nyp/2] -+ i Y(dy)."""
    n_pairs, nyp = out.shape[0], out.shape[1]
    n_basis = z.shape[0]
    half = nyp // 2
    last = min(ext_y - 1, half) if parity else ext_y - 1
    for p in range(n_pairs):
        for dy in range(last + 1):
            up, down = dy, (nyp - dy) % nyp
            sign = 1.0 - 2.0 * (dy % 2)
            for dz in range(keep_z):
                if not parity:
                    acc_up = 0.0j
                    acc_down = 0.0j
                    for b in range(n_basis):
                        w = weights[p, b]
                        acc_up += w * z[b, up, dz]
                        acc_down += w * z[b, down, dz]
                    out[p, up, dz] = acc_up
                    out[p, down, dz] = acc_down
                    continue
                even = 0.0j
                for b in range(n_even):
                    even += weights[p, b] * z[b, dy, dz]
                sym = 0.0j
                anti = 0.0j
                for b in range(n_even, n_basis):
                    w = weights[p, b]
                    sym += w * (z[b, 0, dz] + sign * z[b, half, dz])
                    if 0 < dy < half:
                        y = z[b, dy, dz]
                        anti += w * (y.imag - 1j * y.real)  # -i Y
                out[p, up, dz] = even + sym + anti
                out[p, down, dz] = even + sym - anti
