"""Atmospheric-stability presets for both models (Guo, Schlipf and Cheng 2023, Wind Energ. Sci. 8, 149-171).

Sources of the numbers:

* Mann L, Gamma: Table 1 (after Pena 2019), at U = 16 m/s. alpha*eps^(2/3) is re-derived at every U from the model
  variance for sigma_u = 0.16 (0.75 U + 5.6), the paper's IEC class 1A scaling (Sect. 2.4, 5.1.2); Table 1's value
  (``ae_ref``) is kept for comparison only.
* Evolution time gamma = 600 / 400 / 200 s for unstable / neutral / stable (Sect. 2.4); factor1 = 0.8 for stable
  (the 4D Mann turbulence generator's stable preset), else 1.
* Kaimal L1..L3, a_yz, Lc, sigma_2/sigma_1, sigma_3/sigma_1: Table 1 (fits to the Mann model, Eq. 20-21); neutral is
  the IEC 61400-1 set (Sect. 2.4), Lambda1 = 42 m. sigma_1 follows IEC class A at every U, sigma_2,3 keep the ratios.
* Kaimal a_x, b_x (Eq. 18): Table 2 in the column of the class's gamma, fitted at U = 16 m/s and dx = 100 m, used
  unchanged at other speeds, as in the paper.

User presets: turbgen.spec.preset_files; what a preset gives each model's run: turbgen.spec.preset_runs."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from turbgen.errors import ParameterError, check_choice, check_nonnegative, check_positive
from turbgen.theory.kaimal import IEC_IREF, IEC_LENGTH_FACTORS, IEC_SIGMA_RATIOS
from turbgen.theory.params import KaimalParams, MannParams


@dataclass(frozen=True)
class MannPreset:
    """Mann parameters of a stability class (speed-independent part; ae follows U): L [m], Gamma [-], evolution
    time gamma [s], -factor1 [-] the small-k slope of the Guo lifetime, the lifetime model ("guo" or "mann") and
    ``ae_ref``, Table 1's alpha*eps^(2/3) at 16 m/s [m^(4/3) s^-2], for comparison only."""

    length_scale_m: float
    gamma: float
    evo_time_s: float
    factor1: float = 1.0
    lifetime: str = "guo"
    ae_ref: float | None = None

    def __post_init__(self):
        MannParams(1.0, self.length_scale_m, self.gamma, self.lifetime, self.factor1, evo_time_s=self.evo_time_s)
        if self.ae_ref is not None:
            check_positive("ae_ref (m^(4/3)/s^2)", self.ae_ref)


@dataclass(frozen=True)
class KaimalPreset:
    """Kaimal parameters of a stability class (sigma_1 follows U): sigma_1..3 / sigma_1 [-], L1..L3 [m], yz
    coherence a_yz [-] and Lc [m], Eq. 18 a_x [-] and b_x [1/m] (>= 0)."""

    sigma_ratios: tuple[float, float, float]
    length_scales_m: tuple[float, float, float]
    a_yz: float
    lc_m: float
    a_x: float
    b_x: float

    def __post_init__(self):
        KaimalParams(tuple(self.sigma_ratios), tuple(self.length_scales_m), self.a_yz, self.lc_m)
        object.__setattr__(self, "sigma_ratios", tuple(float(r) for r in self.sigma_ratios))
        object.__setattr__(self, "length_scales_m", tuple(float(v) for v in self.length_scales_m))
        check_nonnegative("a_x", self.a_x)
        check_nonnegative("b_x (1/m)", self.b_x)


@dataclass(frozen=True)
class StabilityPreset:
    """A named stability class: Mann and/or Kaimal parameters (at least one), the IEC class ("A+", "A", "B" or "C")
    that sets the TI, and where the numbers come from (``source``)."""

    name: str
    mann: MannPreset | None
    kaimal: KaimalPreset | None
    turb_class: str = "A"
    source: str = ""

    def __post_init__(self):
        check_choice("turb_class", self.turb_class, tuple(IEC_IREF))
        if self.mann is None and self.kaimal is None:
            raise ParameterError(f"preset {self.name!r} defines neither 'mann' nor 'kaimal' parameters")


@dataclass(frozen=True)
class KaimalSettings:
    """What a Kaimal run takes from a preset: spectra/yz coherence (``kaimal``), the longitudinal model
    ("exp") and its Eq. 18 parameters a_x [-], b_x [1/m]."""

    kaimal: KaimalParams
    long_model: str
    a_x: float
    b_x: float


# Guo et al. 2023, Table 2: (a_x, b_x [1/m]) of Eq. 18 per class, for gamma = 200, 400, 600 s
_TABLE2 = {
    "unstable": {200.0: (8.2, 8.52e-5), 400.0: (5.1, 8.02e-5), 600.0: (4.1, 7.67e-5)},
    "neutral": {200.0: (2.9, 1.59e-4), 400.0: (1.8, 1.49e-4), 600.0: (1.4, 1.42e-4)},
    "stable": {200.0: (1.6, 9.18e-4), 400.0: (1.0, 8.59e-4), 600.0: (0.8, 8.27e-4)},
}
_EVO_S = {"unstable": 600.0, "neutral": 400.0, "stable": 200.0}  # Guo et al. 2023, Sect. 2.4
_IEC_LAMBDA1_M = 42.0  # IEC 61400-1 Lambda1 for hub heights >= 60 m; Table 1 neutral L1 = 8.1 * 42 = 340.2 m
_SOURCE = "Guo et al. 2023, Table 1 ({cls}, U = 16 m/s), gamma from Sect. 2.4, a_x/b_x from Table 2"


def _builtin() -> dict[str, StabilityPreset]:
    def kaimal(cls, ratios, scales, a_yz, lc_m):
        a_x, b_x = _TABLE2[cls][_EVO_S[cls]]
        return KaimalPreset(ratios, scales, a_yz, lc_m, a_x, b_x)

    return {
        "unstable": StabilityPreset(
            "unstable",
            MannPreset(140.0, 2.6, _EVO_S["unstable"], ae_ref=0.184),
            kaimal("unstable", (1.0, 2.34 / 2.82, 1.98 / 2.82), (744.8, 181.9, 126.4), 6.5, 1502.0),
            source=_SOURCE.format(cls="unstable"),
        ),
        "neutral": StabilityPreset(
            "neutral",
            MannPreset(49.0, 3.1, _EVO_S["neutral"], ae_ref=0.311),
            kaimal("neutral", IEC_SIGMA_RATIOS, tuple(c * _IEC_LAMBDA1_M for c in IEC_LENGTH_FACTORS), 12.0,
                   8.1 * _IEC_LAMBDA1_M),
            source=_SOURCE.format(cls="neutral") + "; Kaimal = IEC 61400-1 NTM set",
        ),
        "stable": StabilityPreset(
            "stable",
            MannPreset(30.0, 2.4, _EVO_S["stable"], factor1=0.8, ae_ref=0.652),
            kaimal("stable", (1.0, 2.26 / 2.82, 1.83 / 2.82), (101.1, 33.3, 27.0), 13.1, 101.1),
            source=_SOURCE.format(cls="stable") + "; factor1 = 0.8 (4D Mann generator stable preset)",
        ),
    }


BUILTIN_PRESETS: dict[str, StabilityPreset] = _builtin()


def get_preset(name: str, user: Mapping[str, StabilityPreset] | None = None) -> StabilityPreset:
    """Built-in or ``user`` preset (shadowing built-ins) by name; ParameterError listing the known names otherwise."""
    known = {**BUILTIN_PRESETS, **(user or {})}
    if name not in known:
        raise ParameterError(f"preset = {name!r} is not one of {', '.join(known)}")
    return known[name]
