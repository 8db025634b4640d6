"""Tabulated eddy lifetimes (theory.eddy_lifetime.LifetimeTable): error bound, range ends, k = 0."""

from __future__ import annotations

import numpy as np
import pytest

from turbgen.theory.eddy_lifetime import (
    TABLE_KL_MAX,
    TABLE_KL_MIN,
    TABLE_REL_ERROR,
    LifetimeTable,
    evolution_lifetime_s,
    guo_lifetime,
    mann_lifetime,
)
from turbgen.theory.params import MannParams

# log-uniform kL over the table's range plus its two ends and the node-free middle of an interval
_KL = np.concatenate(
    [
        np.exp(np.random.default_rng(7).uniform(np.log(TABLE_KL_MIN), np.log(TABLE_KL_MAX), 200_000)),
        [TABLE_KL_MIN, TABLE_KL_MAX * (1 - 1e-12), 1.0, np.exp(1 / 128.0)],
    ]
)


@pytest.mark.parametrize(
    "kind, parameter, exact",
    [
        ("mann", 1.0, mann_lifetime),
        ("guo", 1.0, lambda kL: guo_lifetime(kL, 1.0)),
        ("guo", 0.8, lambda kL: guo_lifetime(kL, 0.8)),
        ("guo", 0.1, lambda kL: guo_lifetime(kL, 0.1)),
        ("guo", 3.0, lambda kL: guo_lifetime(kL, 3.0)),
        ("evolution", 3.5, None),
        ("evolution", 10.0, None),
        ("evolution", 0.01, None),
    ],
)
def test_table_error_below_documented_bound(kind, parameter, exact):
    table = LifetimeTable(kind, parameter)
    if exact is None:  # tau_e / gamma from the public Eq. 15 function (gamma = 1 s, L = 1 m)
        params = MannParams(ae=1.0, length_scale_m=1.0, gamma=1.0, factor2=parameter, evo_time_s=1.0)
        ref = evolution_lifetime_s(_KL, params)
    else:
        ref = exact(_KL)
    got = table.from_ksq((_KL / 7.0) ** 2, 7.0)  # |k| = kL / L with L = 7 m
    rel = np.abs(got / ref - 1.0)
    assert rel.max() <= TABLE_REL_ERROR, rel.max()


def test_outside_the_table_is_exact_and_k_zero_is_infinite():
    table = LifetimeTable("mann")
    kL = np.array([1e-9, 1e-7, 2e6, 1e9])
    assert np.array_equal(table.from_ksq(kL**2, 1.0), mann_lifetime(np.sqrt(kL**2)))
    assert np.isinf(table.from_ksq(np.array([0.0]), 49.0)[0])


def test_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="kind"):
        LifetimeTable("kolmogorov")
