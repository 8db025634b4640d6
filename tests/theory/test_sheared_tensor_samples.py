"""The compiled tensor on the quadrature circles equals mann_tensor.sheared_tensor bit for bit (same operations
in the same order, numpy's own arctan2 and powers), including the exact limits: k1 = 0 and subnormal k1,
the k3 axis (theta = +-pi/2), kappa = 0 and |k| below 1e-30 rad/m."""

from __future__ import annotations

import numpy as np
import pytest

from turbgen.theory.eddy_lifetime import shear_distortion_beta
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import MannParams
from turbgen.theory.sheared_tensor_samples import sheared_tensor_on_circles

PAIRS = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]


@pytest.mark.parametrize("params", [
    MannParams(ae=0.08, length_scale_m=49.0, gamma=3.1),
    MannParams(ae=0.3, length_scale_m=30.0, gamma=3.9, lifetime="mann"),
    MannParams(ae=0.05, length_scale_m=140.0, gamma=0.0),
], ids=["guo", "mann", "isotropic"])
def test_equals_the_whole_array_tensor_bit_for_bit(params):
    rng = np.random.default_rng(11)
    k1 = np.concatenate([[0.0, 1e-320, -3e-3, 1e-14], rng.standard_normal(6) * 0.05])
    kappa = np.exp(rng.uniform(-14, 3, (k1.size, 33)))
    kappa[0, 0], kappa[1, 1], kappa[2, 2] = 0.0, 1e-40, 1e-13
    n_theta = 64  # theta = pi/2, 3 pi/2 among the nodes: k2 = kappa cos(theta) ~ 1e-17 kappa, the k3 axis
    theta = 2.0 * np.pi * np.arange(n_theta) / n_theta
    beta = shear_distortion_beta(np.sqrt(k1[:, None] ** 2 + kappa**2), params)
    want = sheared_tensor(k1[:, None, None], kappa[..., None] * np.cos(theta), kappa[..., None] * np.sin(theta),
                          params, beta=beta[..., None])
    got = sheared_tensor_on_circles(k1, kappa, beta, np.cos(theta), np.sin(theta), PAIRS, params.ae,
                                    params.length_scale_m)
    assert got.shape == (len(PAIRS), k1.size, 33, n_theta)
    for m, (i, j) in enumerate(PAIRS):
        assert np.array_equal(got[m].view(np.int64), want[i, j].view(np.int64)), (i, j)
    assert np.all(got[:, 0, 0] == 0.0)  # k = 0 carries nothing


def test_pairs_come_in_the_order_asked():
    params = MannParams(ae=0.08, length_scale_m=49.0, gamma=3.1)
    k1, kappa = np.array([0.01]), np.array([[0.02, 0.5]])
    beta = shear_distortion_beta(np.sqrt(k1[:, None] ** 2 + kappa**2), params)
    c, s = np.cos([0.3, 1.1]), np.sin([0.3, 1.1])
    both = sheared_tensor_on_circles(k1, kappa, beta, c, s, [(1, 2), (0, 0)], params.ae, params.length_scale_m)
    alone = sheared_tensor_on_circles(k1, kappa, beta, c, s, [(2, 1)], params.ae, params.length_scale_m)
    assert np.array_equal(both[0], alone[0]) and not np.array_equal(both[0], both[1])
