"""The per-node sums of the Mann preview spectra (turbgen.theory.lidar_preview), compiled: for every (k2, k3) node the
lidar's transfer functions A_g,l(k) of the gates, the decay recursion along the sorted gates, and their contributions
to S_LL and S_RL (Guo et al. 2023, Eq. 24, 29, 32), one node at a time (nothing of size gates x nodes is formed)."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def node_sums(k1, k2, k3, beams, beam_table, beam_of, nu_step, tables, phase, gate_of, scale, gate_x, phi_w,
              inv_tau, rotor, U):  # fmt: skip
    """(S_LL, S_RL) summed over the nodes (J,) k2, k3 [rad/m] at k1 (two-sided in k1; ``phi_w`` (3, 3, J): the
    tensor times the nodes' weights).

    The decay D_gh = exp(-s |x_g - x_h|), s = 1 / (U tau_e), is summed by the recursion C_h = exp(-s (x_h -
    x_{h-1})) (C_{h-1} + A_{h-1}): O(gates) per node. ``beams`` (B, 3): the distinct LOS vectors, ``beam_table``
    their row of ``tables`` (phi_hat(|nu|) of each probe volume on a |nu| grid of step ``nu_step`` [rad/m], linear
    between), ``beam_of`` each measurement's beam; ``phase`` exp(i (k2 y_i + k3 z_i)); ``gate_of`` each
    measurement's gate (sorted by ``gate_x`` [m]), ``scale`` its n_il / (M n_i1); ``inv_tau`` 1/tau_e [1/s];
    ``rotor`` the rotor's transfer; U [m/s]."""
    n_gates, count, n_beams = len(gate_x), len(beam_of), len(beams)
    last = tables.shape[1] - 1
    a = np.zeros((n_gates, 3), np.complex128)
    hat = np.empty(n_beams)
    s_ll = 0.0
    s_rl = 0.0j
    for j in range(len(k2)):
        for b in range(n_beams):  # phi_hat(|k . n|), linear in the table
            pos = min(abs(k1 * beams[b, 0] + k2[j] * beams[b, 1] + k3[j] * beams[b, 2]) / nu_step, last)
            i0 = min(int(pos), last - 1)
            t = tables[beam_table[b]]
            hat[b] = t[i0] + (pos - i0) * (t[i0 + 1] - t[i0])
        a[:] = 0.0
        for i in range(count):
            p = hat[beam_of[i]] * np.complex128(phase[i, j])
            for col in range(3):
                a[gate_of[i], col] += scale[i, col] * p
        s = inv_tau[j] / U
        c0 = c1 = c2 = 0.0j  # C_h = sum_(g < h) D_gh A_g by the recursion over the sorted gates
        d = math.exp(-s * gate_x[0])  # the decay from gate h to the rotor
        rl = 0.0j
        for h in range(n_gates):
            if h:
                step = math.exp(-s * (gate_x[h] - gate_x[h - 1]))
                c0, c1, c2 = step * (c0 + a[h - 1, 0]), step * (c1 + a[h - 1, 1]), step * (c2 + a[h - 1, 2])
                d *= step
            x0, x1, x2 = np.conj(a[h, 0]), np.conj(a[h, 1]), np.conj(a[h, 2])
            p0 = phi_w[0, 0, j] * x0 + phi_w[0, 1, j] * x1 + phi_w[0, 2, j] * x2  # Phi conj(A_h)
            p1 = phi_w[1, 0, j] * x0 + phi_w[1, 1, j] * x1 + phi_w[1, 2, j] * x2
            p2 = phi_w[2, 0, j] * x0 + phi_w[2, 1, j] * x1 + phi_w[2, 2, j] * x2
            s_ll += ((a[h, 0] + 2 * c0) * p0 + (a[h, 1] + 2 * c1) * p1 + (a[h, 2] + 2 * c2) * p2).real
            rl += d * p0
        s_rl += rl * rotor[j]
    return s_ll, s_rl
