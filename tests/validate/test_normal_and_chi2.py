"""The validator's normal and chi-square functions give scipy.stats' values (bit for bit) without importing it."""

import subprocess
import sys

import numpy as np
import pytest
import scipy.stats

from turbgen.validate import normal_and_chi2 as d

RNG = np.random.default_rng(7)
X = np.concatenate([[-np.inf, -40.0, -8.5, -1.0, -0.0, 0.0, 1e-300, 0.5, 3.0, 8.5, 40.0, np.inf],
                    RNG.normal(0.0, 4.0, 200)])
P = np.concatenate([[0.0, 1e-300, 1e-20, 0.025, 0.5, 0.975, 1 - 1e-16, 1.0], RNG.uniform(0.0, 1.0, 200)])
CHI_X = np.concatenate([[-1.0, 0.0, 1e-12, 0.3, 1.0, 7.0, 300.0, np.inf], RNG.gamma(3.0, 4.0, 200)])


@pytest.mark.parametrize("ours, theirs, args", [
    (d.norm_pdf, scipy.stats.norm.pdf, X), (d.norm_cdf, scipy.stats.norm.cdf, X), (d.norm_sf, scipy.stats.norm.sf, X),
    (d.norm_ppf, scipy.stats.norm.ppf, P), (d.norm_isf, scipy.stats.norm.isf, P),
])  # fmt: skip
def test_normal_functions_equal_scipy_stats(ours, theirs, args):
    np.testing.assert_array_equal(ours(args), theirs(args))


@pytest.mark.parametrize("nu", [0.7, 2.0, 11.3, 480.0, 1e5])
@pytest.mark.parametrize("ours, theirs", [
    (d.chi2_cdf, scipy.stats.chi2.cdf), (d.chi2_sf, scipy.stats.chi2.sf),
    (d.chi2_logcdf, scipy.stats.chi2.logcdf), (d.chi2_logsf, scipy.stats.chi2.logsf),
])  # fmt: skip
def test_chi2_functions_equal_scipy_stats(ours, theirs, nu):
    x = CHI_X * nu / 12.0
    np.testing.assert_array_equal(ours(x, nu), theirs(x, nu))
    nus = np.full(x.shape, nu)  # broadcast degrees of freedom as the validator passes them
    np.testing.assert_array_equal(ours(x, nus), theirs(x, nus))


@pytest.mark.parametrize("nu", [0.7, 2.0, 11.3, 480.0, 1e5])
def test_chi2_ppf_equals_scipy_stats(nu):
    np.testing.assert_array_equal(d.chi2_ppf(P, nu), scipy.stats.chi2.ppf(P, nu))


def test_validate_does_not_import_scipy_stats_or_signal():
    code = "import sys, turbgen.cli.validate; print(sorted(m for m in ('scipy.stats', 'scipy.signal') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
