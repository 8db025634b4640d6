"""ValidationReport.metric: a metric by name, or a KeyError naming the report's metrics (not StopIteration)."""

import pytest

from turbgen.validation import ValidationReport
from turbgen.validation.checks import MetricResult


def test_metric_by_name_and_unknown_name_lists_the_metrics():
    metrics = [MetricResult(name, name, "m^2/s", []) for name in ("spectrum_u", "variance_u")]
    report = ValidationReport(store=None, estimates=None, theory=None, metrics=metrics, seconds={})
    assert report.metric("variance_u") is metrics[1]
    with pytest.raises(KeyError, match="no metric 'u_spectrum' in this report; it has spectrum_u, variance_u"):
        report.metric("u_spectrum")
