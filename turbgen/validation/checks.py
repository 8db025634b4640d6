"""What a validation reports: metrics made of checks (one comparison each) and curves for the plots."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import norm


ALPHA = 1e-3  # family-wise probability that a correct field fails one given metric


@dataclass
class Curve:
    """Per-bin comparison for plots/JSON: estimate with its 95 % band and the expectation."""

    label: str
    f_hz: np.ndarray
    estimate: np.ndarray
    expected: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


@dataclass
class Check:
    """One comparison: a frequency band of one curve (or a scalar)."""

    label: str
    band_hz: tuple[float, float] | None
    estimate: float
    expected: float
    sigma: float
    z: float


@dataclass
class MetricResult:
    """One metric (``quantity``: what is compared, with units): its checks pass when every |z| <= z_crit =
    Phi^-1(1 - ALPHA / (2 n)) (Bonferroni over n checks)."""

    name: str
    title: str
    quantity: str  # what is compared (units)
    checks: list[Check]
    curves: list[Curve] = field(default_factory=list)
    z_crit: float = 0.0

    def __post_init__(self):
        self.z_crit = float(norm.isf(ALPHA / (2 * max(len(self.checks), 1))))

    @property
    def max_abs_z(self) -> float:
        return max((abs(t.z) for t in self.checks), default=0.0)

    @property
    def passed(self) -> bool:
        return self.max_abs_z <= self.z_crit

    @property
    def worst(self) -> Check | None:
        return max(self.checks, key=lambda t: abs(t.z), default=None)

