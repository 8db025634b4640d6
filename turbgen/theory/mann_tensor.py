"""The Mann (1994) uniform-shear spectral tensor and its square-root factor (Mann 1998).

Wavenumbers in rad/m (broadcast together); the tensor in m^5 s^-2 per unit dk1 dk2 dk3, so
sigma_i^2 = ∫ Phi_ii dk (Mann 1994, Eq. 13-19). Outputs have the 3x3 component axes first:
``phi[i, j]`` is shaped like k1. Exact limits are used on k1 = 0 and on the k3 axis; zero at k = 0."""

from __future__ import annotations

import numpy as np
from scipy.special import beta as beta_fn

from turbgen.theory.eddy_lifetime import shear_distortion_beta
from turbgen.theory.params import MannParams


def von_karman_energy(k, ae: float, length_scale_m: float):
    """von Karman spectrum E(k) = ae L^(5/3) (kL)^4 / (1 + (kL)^2)^(17/6) [m^3 s^-2] at |k| [rad/m] (Mann 1994)."""
    kL = np.asarray(k, dtype=float) * length_scale_m
    return ae * length_scale_m ** (5.0 / 3.0) * kL**4 / (1.0 + kL**2) ** (17.0 / 6.0)


def _distortion(k1, k2, k3, params: MannParams, beta=None):
    """Undistorted wavenumber and the rapid-distortion coefficients zeta1, zeta2 (Mann 1994, Eq. 15-17): (k1, k2, k0sq,
    k30, ksq, zeta1, zeta2, E0); on k1 = 0 zeta1 = -beta, zeta2 = 0 (the linear growth of u under shear), on the k3 axis
    zeta = 0. ``beta`` may be precomputed (it depends on |k| only)."""
    k1, k2, k3 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (k1, k2, k3)))
    # |k| < 1e-30 rad/m carries no energy (E ~ k^4) but would underflow k^4: treat it as k = 0
    negligible = k1 * k1 + k2 * k2 + k3 * k3 < 1e-60
    k1, k2, k3 = (np.where(negligible, 0.0, a) for a in (k1, k2, k3))
    ksq = k1 * k1 + k2 * k2 + k3 * k3
    beta = shear_distortion_beta(np.sqrt(ksq), params) if beta is None else beta
    beta = np.broadcast_to(beta, ksq.shape)
    beta = np.where(np.isfinite(beta), beta, 0.0)  # k = 0 carries no energy
    k30 = k3 + beta * k1
    k0sq = k1 * k1 + k2 * k2 + k30 * k30
    q = k1 * k1 + k2 * k2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sq = np.sqrt(q)
        c1 = beta * k1 * k1 * (k0sq - 2.0 * k30 * k30 + beta * k1 * k30) / (ksq * q)
        c2 = k2 * k0sq / (q * sq) * np.arctan2(beta * k1 * sq, k0sq - k30 * k1 * beta)
        ratio = k2 / k1
        zeta1 = c1 - ratio * c2
        zeta2 = ratio * c1 + c2
    # near the k3 axis (q/k^2 < 1e-30, where q^(3/2) may underflow) every zeta term of Phi carries a
    # factor k1 or q, so zeta = 0 there changes Phi by O(1e-15) relative
    axis = q <= 1e-30 * ksq
    # k1 -> 0 at fixed q: zeta1 -> -beta, zeta2 -> 0 (the error of the limit is O(k1/sqrt(q)); it also
    # keeps k2/k1 from overflowing for subnormal k1)
    on_k1_zero = (np.abs(k1) <= 1e-12 * np.sqrt(q)) & ~axis
    zeta1 = np.where(on_k1_zero, -beta, zeta1)
    zeta2 = np.where(on_k1_zero, 0.0, zeta2)
    zeta1 = np.where(axis, 0.0, zeta1)
    zeta2 = np.where(axis, 0.0, zeta2)
    e0 = von_karman_energy(np.sqrt(k0sq), params.ae, params.length_scale_m)
    return k1, k2, k0sq, k30, ksq, zeta1, zeta2, e0


def sheared_tensor(k1, k2, k3, params: MannParams, beta=None):
    """Phi_ij(k) [m^5 s^-2], (3, 3, *k1.shape), of the sheared Mann tensor (Mann 1994, Eq. 19); ``beta`` optionally
    gives beta(|k|) [-] precomputed (see shear_distortion_beta), broadcastable to k1."""
    k1, k2, k0sq, k30, ksq, z1, z2, e0 = _distortion(k1, k2, k3, params, beta)
    q = k1 * k1 + k2 * k2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a = np.where(k0sq > 0, e0 / (4.0 * np.pi * k0sq * k0sq), 0.0)
        b = np.where(ksq > 0, e0 / (4.0 * np.pi * k0sq * ksq), 0.0)
        c = np.where(ksq > 0, e0 / (4.0 * np.pi * ksq * ksq), 0.0)
    phi = np.empty((3, 3) + k1.shape)
    phi[0, 0] = a * (k0sq - k1 * k1 - 2.0 * k1 * k30 * z1 + q * z1 * z1)
    phi[1, 1] = a * (k0sq - k2 * k2 - 2.0 * k2 * k30 * z2 + q * z2 * z2)
    phi[2, 2] = c * q
    phi[0, 1] = phi[1, 0] = a * (-k1 * k2 - k1 * k30 * z2 - k2 * k30 * z1 + q * z1 * z2)
    phi[0, 2] = phi[2, 0] = b * (-k1 * k30 + q * z1)
    phi[1, 2] = phi[2, 1] = b * (-k2 * k30 + q * z2)
    return phi


def tensor_factor(k1, k2, k3, params: MannParams):
    """Real factor C(k) [m^(5/2) s^-1], (3, 3, *k1.shape), with C C^T = Phi (Mann 1998, Eq. 46-47).

    C = D(k) A(k0): A the isotropic factor sqrt(E(k0)/(4 pi))/k0^2 [[0, k30, -k2], [-k30, 0, k1],
    [k2, -k1, 0]] and D = [[1, 0, zeta1], [0, 1, zeta2], [0, 0, k0^2/k^2]]. Times sqrt(dk1 dk2 dk3) it
    gives Fourier amplitudes on a grid."""
    k1, k2, k0sq, k30, ksq, z1, z2, e0 = _distortion(k1, k2, k3, params)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        amp = np.where(k0sq > 0, np.sqrt(e0 / (4.0 * np.pi)) / k0sq, 0.0)
        d33 = np.where(ksq > 0, k0sq / ksq, 0.0)
    iso = np.zeros((3, 3) + k1.shape)
    iso[0, 1], iso[0, 2] = k30, -k2
    iso[1, 0], iso[1, 2] = -k30, k1
    iso[2, 0], iso[2, 1] = k2, -k1
    iso *= amp
    c = iso.copy()
    c[0] += z1 * iso[2]
    c[1] += z2 * iso[2]
    c[2] = d33 * iso[2]
    return c


def isotropic_variance(ae: float, length_scale_m: float) -> float:
    """Component variance (1/3) B(5/2, 1/3) ae L^(2/3) [m^2 s^-2] of the isotropic von Karman field."""
    return beta_fn(2.5, 1.0 / 3.0) / 3.0 * ae * length_scale_m ** (2.0 / 3.0)
