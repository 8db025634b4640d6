"""Validation of a field store against its model: ``turbgen validate STORE`` (docs/validate.md).

``estimators`` reads the Welch estimates, ``expectations`` predicts them for their ``prediction.SamplingDesign``
(in a thread of its own while the store is read), ``verdict`` judges, ``report`` renders."""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass
from functools import partial

from turbgen.errors import ParameterError
from turbgen.store import FieldStore, open_store
from turbgen.validation.estimators import Estimates, plan_estimates, run_estimates
from turbgen.validation.expectations import theory_for
from turbgen.validation.point_sets import DEFAULT_ROTOR_RADIUS_M
from turbgen.validation.prediction import SamplingDesign, Theory
from turbgen.validation.checks import ALPHA, MetricResult
from turbgen.validation.theory_cache import cached, theory_key
from turbgen.validation.verdict import Expectations, expectations, judge


@dataclass
class ValidationReport:
    """Everything a validation found: estimates, theory, per-metric results, timing [s]."""

    store: FieldStore
    estimates: Estimates
    theory: Theory
    metrics: list[MetricResult]
    seconds: dict

    @property
    def passed(self) -> bool:
        """True if every metric passes."""
        return all(m.passed for m in self.metrics)

    @property
    def failed(self) -> list[str]:
        """Names of the failed metrics."""
        return [m.name for m in self.metrics if not m.passed]

    def metric(self, name: str) -> MetricResult:
        """The metric called ``name``; KeyError naming the report's metrics otherwise."""
        for m in self.metrics:
            if m.name == name:
                return m
        raise KeyError(f"no metric {name!r} in this report; it has {', '.join(m.name for m in self.metrics)}")

    def to_dict(self) -> dict:
        from turbgen.validation.report import to_dict

        return to_dict(self)

    def table(self) -> str:
        from turbgen.validation.report import table

        return table(self)

    def __repr__(self) -> str:  # a notebook shows the table, not the arrays behind it
        return self.table()

    def plots(self, directory) -> list:
        from turbgen.validation.report import plots

        return plots(self, directory)


def validate(store, *, rotor_radius_m: float | None = None, nperseg: int | None = None,
             workers: int | None = None) -> ValidationReport:
    """Validate a store (path or FieldStore) against its model (the engine of :func:`turbgen.validate`).

    ``rotor_radius_m`` [m] (None: 63 m, or the largest disc a smaller grid holds); ``nperseg`` [samples];
    ``workers`` dask threads (more than one: the theory alongside the estimates). StoreError or ParameterError for an
    unreadable store, bad input or a conditional-mean store."""
    fs = store if isinstance(store, FieldStore) else open_store(store)
    constraints = fs.attrs.get("constraints")
    if constraints is not None and constraints.get("conditional_mean"):
        raise ParameterError(
            f"{fs.label} holds the conditional mean of a constrained run (--conditional-mean), a smoothed "
            "reconstruction rather than a sample of the model: its statistics are not the model's, so it cannot be "
            "validated (validate a conditional sample instead)"
        )
    t0 = time.perf_counter()
    planned = plan_estimates(fs, rotor_radius_m=rotor_radius_m, nperseg=nperseg)
    parallel = (workers or os.cpu_count() or 1) > 1
    key = theory_key(fs.model, fs.attrs, rotor_radius_m=rotor_radius_m, nperseg=nperseg)
    theory = partial(_timed, cached, key, lambda: _theory(fs, planned))
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="turbgen-theory") if parallel else nullcontext() as pool:
        theory_result = pool.submit(theory).result if pool else theory  # alongside the estimates, or after them
        est = run_estimates(fs, planned, workers)
        t1 = time.perf_counter()
        ((th, expected), kept), theory_s = theory_result()
    t2 = time.perf_counter()
    metrics = judge(est, th, parallel, expected)
    t3 = time.perf_counter()
    seconds = {"estimate": t1 - t0, "theory": theory_s, "verdict": t3 - t2, "total": t3 - t0,
               "theory_kept": kept}  # fmt: skip
    return ValidationReport(fs, est, th, metrics, seconds)


def _theory(fs, planned: Estimates) -> tuple[Theory, Expectations]:
    """The model's predictions for the planned estimates and the expected Welch estimates and covariances the verdict
    compares them with (``planned`` is only read)."""
    th = theory_for(fs, SamplingDesign.of(planned))
    return th, expectations(planned, th)


def _timed(fn, *args):
    """fn(*args) and its wall time [s]."""
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


__all__ = ["ALPHA", "DEFAULT_ROTOR_RADIUS_M", "ValidationReport", "validate"]
