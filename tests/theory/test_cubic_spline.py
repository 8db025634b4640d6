"""The not-a-knot spline of the lifetime tables and the validator equals scipy's CubicSpline bit for bit."""

import subprocess
import sys

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from turbgen.theory.cubic_spline import NotAKnotSpline, not_a_knot_coefficients


@pytest.mark.parametrize("n, trailing", [(4, ()), (5, (3,)), (40, ()), (97, (2, 3)), (3537, ())])
def test_coefficients_and_values_equal_scipy_cubic_spline(n, trailing):
    rng = np.random.default_rng(n)
    x = np.sort(rng.uniform(-5.0, 5.0, n)) if n < 1000 else np.log(1e-6) + np.arange(n) / 128.0  # table-like grid
    y = np.cumsum(rng.normal(size=(n, *trailing)), axis=0)
    ref = CubicSpline(x, y)
    ours = not_a_knot_coefficients(x, y)
    for power in range(4):
        np.testing.assert_array_equal(ours[power], ref.c[power])
    t = np.concatenate([rng.uniform(x[0] - 1.0, x[-1] + 1.0, 300), x])  # inside, outside, on the nodes
    np.testing.assert_array_equal(NotAKnotSpline(x, y)(t), ref(t))


def test_a_cubic_is_reproduced():
    # the not-a-knot spline through samples of a cubic is that cubic (exact up to rounding)
    x = np.array([0.0, 0.3, 1.1, 1.7, 2.0, 3.5])
    f = lambda t: 2.0 * t**3 - t**2 + 0.5 * t - 4.0  # noqa: E731
    t = np.linspace(-0.5, 4.0, 50)
    np.testing.assert_allclose(NotAKnotSpline(x, f(x))(t), f(t), rtol=0, atol=1e-12)


@pytest.mark.parametrize("x, y", [([0.0, 1.0, 2.0], [1.0, 2.0, 3.0]), ([0.0, 2.0, 1.0, 3.0], [1.0, 2.0, 3.0, 4.0]),
                                  ([0.0, 1.0, 2.0, 3.0], [1.0, 2.0, 3.0])])  # fmt: skip
def test_bad_nodes_are_refused(x, y):
    with pytest.raises(ValueError):
        not_a_knot_coefficients(x, y)


def test_mann_and_validate_start_without_scipy_interpolate():
    code = ("import sys, turbgen.cli.mann, turbgen.cli.validate, turbgen.theory.eddy_lifetime as e; "
            "e.lifetime_table('mann'); print('scipy.interpolate' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
