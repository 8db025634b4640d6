"""The numpy stencil of turbgen 34862bc (whole-array passes), kept as the reference of the compiled stencil kernel.

``reference_axis_cells`` is the former slab-by-slab ``turbgen.synthesis.mann_cells.axis_cells`` (now batched).

``reference_unit_factors`` is the former ``turbgen.synthesis.mann_stencil._unit_coefficients`` operation by
operation; ``reference_coefficients`` applies the energy as ``mann_factors.apply_energy`` does. The compiled
kernel evaluates the same float64 operations in the same order point by point, except that log, exp and arctan
come from the C library instead of numpy's SIMD loops (they differ in the last bit of a few per cent of values).

``discrete_spectra`` is the exact expectation of the synthesised field from ``mann_oracle.slab_factor``.
"""

from __future__ import annotations

import numpy as np

from turbgen.synthesis.mann_cells import CELL_K1_FACTOR, CELL_RADIUS, _cell_rule
from turbgen.theory.lattice import gauss_panel
from turbgen.synthesis.box_shape import BoxShape
from turbgen.synthesis.mann_factors import energy_scale
from turbgen.synthesis.mann_oracle import slab_factor
from turbgen.theory.eddy_lifetime import evolution_lifetime_table, shear_lifetime_table
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import MannParams


def _even_in_k3(table, ksq: np.ndarray, length_scale_m: float) -> np.ndarray:
    nzp = ksq.shape[-1]
    h = nzp // 2
    out = np.empty(ksq.shape)
    out[..., : h + 1] = table.from_ksq(ksq[..., : h + 1], length_scale_m)
    out[..., h + 1 :] = out[..., nzp - h - 1 : 0 : -1]
    return out


def _unit_coefficients(params: MannParams, k1, k2, k3, out: np.ndarray, inv_tau: np.ndarray | None) -> None:
    L = params.length_scale_m
    q = k1 * k1 + k2 * k2  # (b, nh, 1)
    ksq = q + k3 * k3  # (b, nh, nzp)
    e, k30, z1, z2 = out
    if params.gamma == 0.0:
        beta = np.zeros_like(ksq)
    else:
        beta = _even_in_k3(shear_lifetime_table(params), ksq, L)
        beta *= params.gamma
    with np.errstate(invalid="ignore"):
        bk1 = beta * k1
    np.add(bk1, k3, out=k30)
    k0sq = k30 * k30
    k0sq += q
    np.multiply(k0sq, L * L, out=e)
    e += 1.0
    np.log(e, out=e)
    e *= -17.0 / 12.0
    np.exp(e, out=e)
    with np.errstate(divide="ignore", invalid="ignore"):
        sq = np.sqrt(q)
        c1 = np.multiply(bk1, k30, out=z1)
        c1 -= 2.0 * k30 * k30
        c1 += k0sq
        c1 *= bk1 * k1
        c1 /= ksq * q
        x = k0sq - k30 * bk1
        c2 = np.arctan(np.divide(bk1 * sq, x, out=z2), out=z2)
        c2 -= np.pi * (x < 0)
        c2 *= k0sq
        c2 *= k2 / (q * sq)
        ratio = k2 / k1
        c1_ratio = c1 * ratio
        c1 -= c2 * ratio
        c2 += c1_ratio
    for i in np.flatnonzero(k1[:, 0, 0] == 0.0):
        np.negative(beta[i], out=z1[i])
        z2[i] = 0.0
        z1[i, q[i, :, 0] == 0] = 0.0
        origin = ksq[i] == 0
        for f in (e, k30, z1, z2):
            f[i, origin] = 0.0
    if inv_tau is not None:
        tau = _even_in_k3(evolution_lifetime_table(params), ksq, L)
        tau *= params.evo_time_s
        np.divide(1.0, tau, out=inv_tau)


def reference_unit_factors(params: MannParams, box: BoxShape, with_tau: bool):
    """(e, k30, c1, c2) (4, nk1, nh, nzp) float64 and 1/tau_e (nk1, nh, nzp) float64 (or None) of the numpy code."""
    nh = box.nk2_half
    k1 = box.k1()[:, None, None]
    out = np.empty((4, box.nk1, nh, box.nzp))
    inv_tau = np.empty((box.nk1, nh, box.nzp)) if with_tau else None
    _unit_coefficients(params, k1, box.k2()[:nh][:, None], box.k3(), out, inv_tau)
    return out, inv_tau


def reference_coefficients(params: MannParams, box: BoxShape, with_tau: bool):
    """(A, P, Z1, Z2) (4, nk1, nh, nzp) float32 and 1/tau_e float32 (or None) of the numpy code."""
    unit, inv_tau = reference_unit_factors(params, box, with_tau)
    scale = np.sqrt(np.prod(box.dk()) / 2.0)
    a, p, z1, z2 = out = np.empty_like(unit)
    np.multiply(unit[0], energy_scale(params), out=a)
    np.multiply(unit[1], a, out=p)
    np.multiply(unit[2], a, out=z1)
    np.multiply(unit[3], a, out=z2)
    for i in np.flatnonzero(box.k1() == 0.0):
        a[i, 0] = 0.0
    out *= scale
    return out.astype(np.float32), None if inv_tau is None else inv_tau.astype(np.float32)


def reference_axis_cells(params: MannParams, box: BoxShape) -> tuple[np.ndarray, np.ndarray]:
    """(cell_index, cell_factor) as the slab-by-slab axis_cells of 34862bc computed them."""
    dk1, dk2, dk3 = box.dk()
    r2 = min(CELL_RADIUS, (box.nyp - 1) // 2)
    r3 = min(CELL_RADIUS, (box.nzp - 1) // 2)
    n_slabs = min(box.nk1, int(CELL_K1_FACTOR * max(dk2, dk3) / dk1) + 1)
    table = shear_lifetime_table(params)
    js, ls = np.arange(-r2, r2 + 1), np.arange(-r3, r3 + 1)
    n3 = len(ls)
    index, factor = [], []
    for i in range(n_slabs):
        k1c = box.k1()[i]
        x1, w1 = gauss_panel(k1c - dk1 / 2, k1c + dk1 / 2, 2)
        scale = max(abs(k1c), dk1 / 4)
        rules2 = [_cell_rule(j * dk2, dk2, scale) for j in js]
        rules3 = [_cell_rule(l * dk3, dk3, scale) for l in ls]
        x2, w2 = np.concatenate([r[0] for r in rules2]), np.concatenate([r[1] for r in rules2])
        x3, w3 = np.concatenate([r[0] for r in rules3]), np.concatenate([r[1] for r in rules3])
        id2 = np.repeat(np.arange(len(js)), [len(r[0]) for r in rules2])
        id3 = np.repeat(np.arange(n3), [len(r[0]) for r in rules3])
        shape = (len(x1), len(x2), len(x3))
        k1n, k2n, k3n = (np.broadcast_to(v, shape).ravel() for v in (x1[:, None, None], x2[None, :, None], x3))
        weight = (w1[:, None, None] * w2[None, :, None] * w3[None, None, :]).ravel()
        cell = np.broadcast_to(id2[None, :, None] * n3 + id3[None, None, :], shape).ravel()
        beta = params.gamma * table.from_ksq(k1n * k1n + k2n * k2n + k3n * k3n, params.length_scale_m)
        phi = sheared_tensor(k1n, k2n, k3n, params, beta=beta) * weight
        ncell = len(js) * n3
        cells = np.stack([[np.bincount(cell, phi[a, b], minlength=ncell) for b in range(3)] for a in range(3)]) / 2.0
        if i == 0:
            cells[:, :, r2 * n3 + r3] = 0.0
        lam, vec = np.linalg.eigh(np.moveaxis(cells, -1, 0))  # the principal square root V sqrt(Lambda) V^T
        factor.append((vec * np.sqrt(np.clip(lam, 0.0, None))[:, None, :]) @ np.swapaxes(vec, -1, -2))
        index.extend((i, j % box.nyp, l % box.nzp) for j in js for l in ls)
    index = np.array(index, dtype=np.int64).reshape(-1, 3)
    factor = np.concatenate(factor).astype(np.float32) if factor else np.zeros((0, 3, 3), np.float32)
    return index, factor


def discrete_spectra(stencil) -> np.ndarray:
    """S[i, j, slab] = sum over (k2, k3) of E[u_hat_i u_hat_j^*], (3, 3, nk1) real [m^2 s^-2]: a point's variance is
    sum_slab w_slab S[i, i, slab], w = 1 on the k1 = 0 and Nyquist slabs, 2 elsewhere (the Hermitian partner)."""
    out = np.empty((3, 3, stencil.box.nk1))
    for i in range(stencil.box.nk1):
        c = slab_factor(stencil, i)
        out[:, :, i] = 2.0 * np.einsum("ikyz,jkyz->ij", c, c)
    return out
