"""The Mann (1998) factors of the stencil's slabs, from Mann (1994) Eq. 13-17.

apply_energy uses a direct build's float64 operations, so a unit stencil scaled to ae is bit-identical to it."""

from __future__ import annotations

import numpy as np

from turbgen.synthesis.box_shape import BoxShape
from turbgen.theory.eddy_lifetime import evolution_lifetime_table, shear_lifetime_table
from turbgen.theory.params import MannParams


def _table_half(table, log_kl_sq: np.ndarray, ksq, length_scale_m: float) -> np.ndarray:
    """``table.from_ksq`` from ln(|k|^2 L^2) ``log_kl_sq``: the compiled spline (mann_factor_kernel.table_spline, the
    operations of from_ksq), and ``table.exact`` outside the table's range (k = 0 among them) as from_ksq does;
    ``ksq()`` gives |k|^2 [rad^2/m^2] shaped like ``log_kl_sq`` (needed only there)."""
    from turbgen.synthesis.mann_factor_kernel import table_spline

    out = np.empty_like(log_kl_sq)
    if table_spline(log_kl_sq, 0.5 / table.h, table.x0 / table.h, table.h, table.n_intervals, *table.coefficients, out):
        outside = np.isnan(out)
        out[outside] = table.exact(np.sqrt(ksq()[outside]) * length_scale_m)
    return out


def slab_factors(params: MannParams, box: BoxShape, i0: int, i1: int, out, inv_tau, energy: float | None) -> None:
    """The factors of slabs [i0, i1) of ``box`` into ``out`` (i1 - i0, nyp//2+1, nzp); ``energy`` None: ae-free
    (e, k30, c1, c2) float64 (c1, c2: zeta1, zeta2 of Mann 1994 Eq. 13-17); else (A, P, Z1, Z2) float32 as apply_energy
    forms them. 1/tau_e [1/s] into ``inv_tau`` unless None."""
    from turbgen.synthesis import mann_factor_kernel as kernel

    L = params.length_scale_m
    k1, k2, k3 = box.k1()[i0:i1], box.k2()[: box.nk2_half], box.k3()
    k3_half = k3[: box.nzp // 2 + 1]
    half = (k1.size, k2.size, k3_half.size)

    def ksq() -> np.ndarray:
        squares = np.empty(half)
        kernel.squared_wavenumbers(k1, k2, k3_half, 1.0, squares)
        return squares

    log_kl_sq = np.empty(half)
    kernel.squared_wavenumbers(k1, k2, k3_half, L * L, log_kl_sq)
    with np.errstate(divide="ignore"):
        np.log(log_kl_sq, out=log_kl_sq)  # -inf at k = 0
    if params.gamma == 0.0:
        beta = np.zeros(half)
    else:
        beta = _table_half(shear_lifetime_table(params), log_kl_sq, ksq, L)
        beta *= params.gamma
    if inv_tau is None:
        inv_tau_half, inv_tau = np.empty((0, 0, 0)), np.empty((0, 0, 0), np.float32)
    else:
        inv_tau_half = _table_half(evolution_lifetime_table(params), log_kl_sq, ksq, L)
        inv_tau_half *= params.evo_time_s  # tau_e [s] (inf at k = 0)
        np.divide(1.0, inv_tau_half, out=inv_tau_half)
    e = np.empty(out[0].shape)
    arctan = np.empty(out[0].shape)
    kernel.transcendental_arguments(k1, k2, k3, beta, L * L, e, arctan)
    with np.errstate(invalid="ignore"):  # nan at k = 0 (beta = inf there; replaced by 0)
        np.log(e, out=e)
        e *= -17.0 / 12.0
        np.exp(e, out=e)
        np.arctan(arctan, out=arctan)
    out = [np.asarray(f) for f in out]  # plain arrays (the stencil cache passes a memory map)
    kernel.mann_factors(k1, k2, k3, beta, inv_tau_half, e, arctan, energy is None, 1.0 if energy is None else energy,
                        np.sqrt(np.prod(box.dk()) / 2.0), *out, inv_tau)


def energy_scale(params: MannParams) -> float:
    """The factor a / e = sqrt(ae L^(17/3) / (4 pi)) [m^(7/2) s^-1] of the von Karman amplitude (Mann 1998, Eq. 46), from
    ``params``' ae and length scale: the only place where ae enters the stencil's coefficients."""
    return np.sqrt(params.ae * params.length_scale_m ** (17.0 / 3.0) / (4.0 * np.pi))


def apply_energy(unit: np.ndarray, energy: float, k1, scale: float, out: np.ndarray) -> np.ndarray:
    """(A, P, Z1, Z2) = (a, k30 a, c1 a, c2 a) times ``scale`` = sqrt(dk / 2), a = e ``energy``, from ``unit``."""
    a, p, z1, z2 = out
    np.multiply(unit[0], energy, out=a)
    np.multiply(unit[1], a, out=p)
    np.multiply(unit[2], a, out=z1)
    np.multiply(unit[3], a, out=z2)
    for i in np.flatnonzero(k1[:, 0, 0] == 0.0):
        a[i, 0] = 0.0  # row 0 is k2 = 0
    out *= scale
    return out
