"""Atmospheric-stability presets for both models (Guo et al. 2023, Tables 1 and 2).

Sources of every number (Guo, Schlipf and Cheng 2023, Wind Energ. Sci. 8, 149-171: lidar-assisted control under various turbulence characteristics):

* Mann alpha*eps^(2/3), L, Gamma: Table 1 (after Pena 2019), at the reference speed U = 16 m/s.
  alpha*eps^(2/3) is NOT taken from the table: the paper scales it "such that the turbulence
  intensity corresponds to the IEC 61400-1:2019 class 1A definition" (Sect. 2.4, 5.1.2), so it
  is re-derived here from the model variance (turbgen.theory.mann_spectra.ae_for_sigma_u) for
  sigma_u = 0.16 (0.75 U + 5.6) at every U; the table value is kept for comparison only
  (the re-derived value is within a few % of it at 16 m/s).
* Evolution time constant gamma = 600 / 400 / 200 s for unstable / neutral / stable (Sect. 2.4).
* factor1 = 0.8 (Guo lifetime small-k slope -0.8) for the stable class: the 4D Mann turbulence
  generator's stable preset (its stable class needs the slope b1 = -0.8);
  1.0 (the Mann-like slope) otherwise.
* Kaimal L1, L2, L3, a_yz, Lc and sigma_2/sigma_1, sigma_3/sigma_1: Table 1 (fitted to the Mann
  spectra and co-coherence, Eqs. 20-21). The neutral class is the IEC 61400-1 set (Sect. 2.4:
  "we chose the parameters listed by the IEC"), so its ratios are exactly 0.8 and 0.5 and its
  length scales 8.1/2.7/0.66 Lambda1 with Lambda1 = 42 m (Table 1: 2.25/2.82, 1.41/2.82, 340.2,
  113.4, 27.72 m). sigma_1 = 0.16 (0.75 U + 5.6) (IEC class A) at every U; sigma_2, sigma_3
  keep the Table 1 ratios to sigma_1 (Sect. 5.1.2: "sigma_1, sigma_2 and sigma_3 are adjusted
  according to the mean wind").
* Kaimal longitudinal coherence a_x, b_x (exponential model, Eq. 18): Table 2, the column of the
  class's gamma (unstable 600 s: 4.1, 7.67e-5; neutral 400 s: 1.8, 1.49e-4; stable 200 s:
  1.6, 9.18e-4 1/m). They are
  fitted at U = 16 m/s and Delta x = 100 m and used unchanged at other speeds, as in the paper.

User presets (TOML or JSON files): turbgen.spec.preset_files. What a preset gives each model's run:
turbgen.spec.preset_runs.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from turbgen.errors import ParameterError, check_choice, check_nonnegative, check_positive
from turbgen.theory.kaimal import IEC_IREF, IEC_LENGTH_FACTORS, IEC_SIGMA_RATIOS
from turbgen.theory.params import KaimalParams, MannParams

REFERENCE_U_M_S = 16.0  # Guo et al. 2023, Table 1 caption: "with the mean wind speed of 16 m/s"


@dataclass(frozen=True)
class MannPreset:
    """Mann parameters of a stability class (speed-independent part; ae follows U).

    Parameters
    ----------
    length_scale_m, gamma, evo_time_s : float
        L [m], Gamma [-] and evolution time gamma [s] (ranges of turbgen.theory.ranges).
    factor1 : float, optional
        The small-k slope of the Guo lifetime is -factor1 [-] (default 1).
    lifetime : {"guo", "mann"}, optional
        Lifetime model (default "guo").
    ae_ref : float, optional
        Table 1 alpha*eps^(2/3) at 16 m/s [m^(4/3) s^-2] (> 0), for comparison only.

    Raises
    ------
    ParameterError
        If a value is outside its range.
    """

    length_scale_m: float
    gamma: float
    evo_time_s: float
    factor1: float = 1.0
    lifetime: str = "guo"
    ae_ref: float | None = None  # Table 1 alpha*eps^(2/3) at 16 m/s [m^(4/3) s^-2], for comparison only

    def __post_init__(self):
        # Validate with the one place that checks Mann parameters (ae is a placeholder here).
        MannParams(1.0, self.length_scale_m, self.gamma, self.lifetime, self.factor1, evo_time_s=self.evo_time_s)
        if self.ae_ref is not None:
            check_positive("ae_ref (m^(4/3)/s^2)", self.ae_ref)


@dataclass(frozen=True)
class KaimalPreset:
    """Kaimal parameters of a stability class (sigma_1 follows U; ratios, scales and coherences fixed).

    Parameters
    ----------
    sigma_ratios, length_scales_m : tuple of float
        sigma_1..3 / sigma_1 [-] and Kaimal L1..L3 [m].
    a_yz, lc_m, a_x, b_x : float
        yz coherence a_yz [-] and Lc [m]; Eq. 18 a_x [-] (>= 0) and b_x [1/m] (>= 0).

    Raises
    ------
    ParameterError
        If a value is outside its range.
    """

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
    """A named stability class: Mann and/or Kaimal parameters, the IEC class that sets the TI.

    Parameters
    ----------
    name : str
        Preset name.
    mann : MannPreset or None
        Mann parameters.
    kaimal : KaimalPreset or None
        Kaimal parameters (at least one of ``mann``, ``kaimal`` is given).
    turb_class, source : str, optional
        IEC class "A+", "A" (default), "B" or "C"; where the numbers come from.

    Raises
    ------
    ParameterError
        For an unknown class or neither ``mann`` nor ``kaimal``.
    """

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
    """What a Kaimal run takes from a preset: spectra/yz coherence and the exponential a_x, b_x.

    Parameters
    ----------
    kaimal : KaimalParams
        Spectra and yz coherence (sigmas [m/s], L1..L3 [m], a_yz [-], Lc [m]).
    long_model : str
        Longitudinal coherence model ("exp").
    a_x, b_x : float
        Eq. 18 parameters a_x [-] and b_x [1/m].
    """

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
            kaimal(
                "neutral",
                IEC_SIGMA_RATIOS,
                tuple(c * _IEC_LAMBDA1_M for c in IEC_LENGTH_FACTORS),
                12.0,
                8.1 * _IEC_LAMBDA1_M,
            ),
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
    """Built-in or user preset by name; ParameterError listing the known names otherwise.

    Parameters
    ----------
    name : str
        Preset name.
    user : Mapping of str to StabilityPreset, optional
        User presets (shadowing built-in ones of the same name).

    Returns
    -------
    StabilityPreset

    Raises
    ------
    ParameterError
        If ``name`` is not a known preset.
    """
    known = {**BUILTIN_PRESETS, **(user or {})}
    if name not in known:
        raise ParameterError(f"preset = {name!r} is not one of {', '.join(known)}")
    return known[name]
