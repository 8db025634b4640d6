"""The compiled OU step and u_hat = C n (synthesis.mann_product) against the numpy formulation it replaced.

The reference below is MannSnapshots' former numpy code path: the OU update on the mirrored k2 halves, W from
mann_stencil.w_coefficient, and the 3x3 product as a sequence of whole-array operations (Mann 1998 Eq. 46-47).
The kernel must give the same float32 numbers; numpy's complex64 x float32 product is complex x (r + 0j), which can
give a zero of the other sign than the real products of the kernel (see mann_product), so bits are compared on
non-zero values and zeros only by value.
"""

from __future__ import annotations

import numpy as np
import pytest

from turbgen.synthesis.mann_product import ou_product
from turbgen.synthesis.mann_stencil import BoxShape, build_stencil, w_coefficient
from turbgen.theory.params import MannParams


def _multiply(n, uh, a, p, z1, z2, w, k1, k2, mix, tmp, real):
    n0, n1, n2 = n[:, 0], n[:, 1], n[:, 2]
    uu, uv, uw = uh[:, 0], uh[:, 1], uh[:, 2]
    np.multiply(n0, k2, out=mix)
    np.multiply(n1, k1, out=tmp)
    mix -= tmp
    np.multiply(w, mix, out=uw)
    np.multiply(p, n1, out=uu)
    np.multiply(a, k2, out=real)
    np.multiply(real, n2, out=tmp)
    uu -= tmp
    np.multiply(z1, mix, out=tmp)
    uu += tmp
    np.multiply(a, k1, out=real)
    np.multiply(real, n2, out=tmp)
    np.multiply(p, n0, out=uv)
    np.subtract(tmp, uv, out=uv)
    np.multiply(z2, mix, out=tmp)
    uv += tmp


def _reference(n, fresh, rho, sig, coef, k1v, k2v, k3sq, evolve):
    """(new n, u_hat) of b slabs: n, fresh complex64 (b, 3, nyp, nzp); rho, sig, coef[q] on the rows k2 >= 0."""
    n, fresh = n.copy(), fresh.copy()
    b, _, nyp, nzp = n.shape
    nh = coef.shape[2]
    halves = [(slice(0, nh), slice(0, nh))]
    if nyp > nh:
        halves.append((slice(nh, nyp), slice(nyp - nh, 0, -1)))
    if evolve:
        for rows, half in halves:
            n[:, :, rows] *= rho[:, None, half]
            fresh[:, :, rows] *= sig[:, None, half]
        n += fresh
    a, p, z1, z2 = coef
    k1 = k1v[:, None, None]
    k2 = k2v[:, None]
    q = k1 * k1 + (k2 * k2)[:nh]
    w = w_coefficient(a, p, q, q + k3sq, np.empty((b, nh, nzp), np.float32), np.empty((b, nh, nzp), np.float32))
    uhat = np.empty_like(n)
    mix, tmp = np.empty((2, b, nyp, nzp), np.complex64)
    real = np.empty((b, nyp, nzp), np.float32)
    for rows, half in halves:
        zeta2 = z2 if half.start == 0 else -z2[:, half]
        _multiply(n[:, :, rows], uhat[:, :, rows], a[:, half], p[:, half], z1[:, half], zeta2, w[:, half], k1,
                  k2[rows], mix[:, rows], tmp[:, rows], real[:, rows])
    return n, uhat


def _kernel(n, fresh, rho, sig, coef, j0, k1, k2, k3sq, evolve):
    n, uhat = n.copy(), np.empty_like(n)
    ou_product(n.view(np.float32), fresh.view(np.float32), rho, sig, coef, j0, k1, k2, k3sq, uhat.view(np.float32),
               evolve)
    return n, uhat


def _same(got, want):
    assert np.array_equal(got, want)
    bits_differ = got.view(np.uint32) != want.view(np.uint32)
    assert not np.any(bits_differ & (want.view(np.float32) != 0))


def _complex(rng, shape, zeros):
    x = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(np.complex64)
    f = x.view(np.float32)
    f[rng.random(f.shape) < zeros] = np.float32(0.0)
    f[rng.random(f.shape) < zeros] = np.float32(-0.0)
    return x


@pytest.mark.parametrize("evolve", [True, False])
@pytest.mark.parametrize("b, nyp, nzp", [(4, 8, 8), (3, 15, 13), (4, 16, 9), (1, 1, 4), (2, 2, 3), (2, 6, 128)])
def test_kernel_equals_numpy_on_random_numbers(b, nyp, nzp, evolve):
    rng = np.random.default_rng(nyp * 1000 + nzp)
    nh = nyp // 2 + 1
    n, fresh = _complex(rng, (b, 3, nyp, nzp), 0.05), _complex(rng, (b, 3, nyp, nzp), 0.05)
    rho = rng.random((b, nh, nzp)).astype(np.float32)
    rho[rng.random(rho.shape) < 0.1] = 0.0
    rho[rng.random(rho.shape) < 0.1] = 1.0
    sig = np.sqrt(np.float32(1.0) - rho * rho)
    coef = rng.standard_normal((4, b, nh, nzp)).astype(np.float32)
    coef[rng.random(coef.shape) < 0.1] = 0.0
    coef[rng.random(coef.shape) < 0.05] = -0.0
    k1 = -np.arange(b, dtype=np.float32) * np.float32(0.3)
    k2 = (np.fft.fftfreq(nyp) * nyp * 0.7).astype(np.float32)
    k2[nyp // 2] = abs(k2[nyp // 2])
    k3sq = ((np.fft.fftfreq(nzp) * nzp * 0.5) ** 2).astype(np.float32)
    want = _reference(n, fresh, rho, sig, coef, k1, k2, k3sq, evolve)
    j0 = 2  # the batch's slabs start at stencil slab 2 (a batch inside a stencil, or a part of one)
    stencil = np.concatenate([np.full((4, j0, nh, nzp), np.nan, np.float32), coef], axis=1)
    got = _kernel(n, fresh, rho, sig, stencil, j0, k1, k2, k3sq, evolve)
    _same(got[0], want[0])
    _same(got[1], want[1])


def test_kernel_equals_numpy_on_a_stencil():
    box = BoxShape(nt=16, dx_m=8.0, nyp=8, nzp=8, dy_m=6.0, dz_m=6.0)
    st = build_stencil(MannParams(ae=0.3, length_scale_m=49.0, gamma=3.1, evo_time_s=400.0), box)
    rng = np.random.default_rng(5)
    k1 = box.k1().astype(np.float32)
    k2 = box.k2().astype(np.float32)
    k3sq = (box.k3() ** 2).astype(np.float32)
    for i0 in range(0, box.nk1, 4):
        i1 = min(i0 + 4, box.nk1)
        n, fresh = _complex(rng, (i1 - i0, 3, box.nyp, box.nzp), 0.0), _complex(rng, (i1 - i0, 3, box.nyp, box.nzp), 0.0)
        rho = np.exp(st.inv_tau[i0:i1] * np.float32(-0.7))
        sig = np.sqrt(np.float32(1.0) - rho * rho)
        for evolve in (True, False):
            want = _reference(n, fresh, rho, sig, st.coef[:, i0:i1], k1[i0:i1], k2, k3sq, evolve)
            got = _kernel(n, fresh, rho, sig, st.coef, i0, k1[i0:i1], k2, k3sq, evolve)
            _same(got[0], want[0])
            _same(got[1], want[1])
