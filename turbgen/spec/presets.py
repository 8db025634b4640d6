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

User presets: a TOML or JSON file ``{"presets": {NAME: {...}}}`` (or the mapping NAME -> {...}
directly), each with an optional ``mann`` table (L, gamma, evo, factor1, lifetime, ae_ref) and an
optional ``kaimal`` table (sigma_ratios, length_scales_m, a_yz, lc_m, a_x, b_x), plus
``turb_class`` (IEC class, default "A") and ``source`` (free text).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

from turbgen.errors import ParameterError, check_choice, check_nonnegative, check_positive
from turbgen.spec.config import read_config
from turbgen.spec.mann import MannRun
from turbgen.theory.kaimal import IEC_IREF, IEC_LENGTH_FACTORS, IEC_SIGMA_RATIOS, iec_sigma1_m_s
from turbgen.theory.params import KaimalParams, MannParams, check_wind_speed

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


def _table(data: Mapping, where: str, allowed: set[str]) -> dict:
    if not isinstance(data, Mapping):
        raise ParameterError(f"{where} must be a table/object, got {type(data).__name__}")
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise ParameterError(f"{where}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(sorted(allowed))}")
    return dict(data)


def preset_from_mapping(name: str, data: Mapping) -> StabilityPreset:
    """Build a preset from a plain mapping (one entry of a user preset file).

    Parameters
    ----------
    name : str
        New preset name: letters, digits, '-' or '_', not a built-in name.
    data : Mapping
        Optional ``mann`` and ``kaimal`` tables, ``turb_class``, ``source`` (see the module docstring).

    Returns
    -------
    StabilityPreset

    Raises
    ------
    ParameterError
        For a bad or built-in name, an unknown or missing key, or a value outside its range.
    """
    if not isinstance(name, str) or not name or not name.replace("-", "").replace("_", "").isalnum():
        raise ParameterError(f"preset name {name!r} must be a non-empty word of letters, digits, '-' or '_'")
    if name in BUILTIN_PRESETS:
        raise ParameterError(f"preset name {name!r} is built in; choose another name for a user preset")
    d = _table(data, f"preset {name!r}", {"mann", "kaimal", "turb_class", "source"})
    mann = kaimal = None
    try:
        if "mann" in d:
            m = _table(d["mann"], f"preset {name!r} mann", {"L", "gamma", "evo", "factor1", "lifetime", "ae_ref"})
            missing = {"L", "gamma", "evo"} - set(m)
            if missing:
                raise ParameterError(f"preset {name!r} mann: missing {', '.join(sorted(missing))}")
            mann = MannPreset(
                m["L"], m["gamma"], m["evo"], m.get("factor1", 1.0), m.get("lifetime", "guo"), m.get("ae_ref")
            )
        if "kaimal" in d:
            keys = {"sigma_ratios", "length_scales_m", "a_yz", "lc_m", "a_x", "b_x"}
            k = _table(d["kaimal"], f"preset {name!r} kaimal", keys)
            missing = keys - set(k)
            if missing:
                raise ParameterError(f"preset {name!r} kaimal: missing {', '.join(sorted(missing))}")
            kaimal = KaimalPreset(
                tuple(k["sigma_ratios"]), tuple(k["length_scales_m"]), k["a_yz"], k["lc_m"], k["a_x"], k["b_x"]
            )
    except TypeError as exc:
        raise ParameterError(f"preset {name!r}: {exc}") from None
    return StabilityPreset(name, mann, kaimal, d.get("turb_class", "A"), str(d.get("source", "user preset")))


def presets_from_mapping(data: Mapping) -> dict[str, StabilityPreset]:
    """``{"presets": {NAME: {...}}}`` or ``{NAME: {...}}`` -> {name: StabilityPreset}.

    Parameters
    ----------
    data : Mapping
        The content of a user preset file.

    Returns
    -------
    dict of str to StabilityPreset

    Raises
    ------
    ParameterError
        If the table is not a mapping or an entry is invalid (see :func:`preset_from_mapping`).
    """
    table = data.get("presets", data) if isinstance(data, Mapping) else data
    if not isinstance(table, Mapping):
        raise ParameterError("user presets must be a table/object NAME -> parameters")
    return {name: preset_from_mapping(name, entry) for name, entry in table.items()}


def load_presets(path: str | Path) -> dict[str, StabilityPreset]:
    """Read user presets from a TOML or JSON file.

    Parameters
    ----------
    path : str or Path
        The file (``.json`` is JSON, anything else TOML).

    Returns
    -------
    dict of str to StabilityPreset

    Raises
    ------
    ParameterError
        If the file is unreadable or invalid, or a preset is invalid.
    """
    return presets_from_mapping(read_config(path))


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


def _resolve(preset: str | StabilityPreset, user) -> StabilityPreset:
    return preset if isinstance(preset, StabilityPreset) else get_preset(preset, user)


def mann_params_for(
    preset: str | StabilityPreset,
    U_m_s: float,
    *,
    user: Mapping[str, StabilityPreset] | None = None,
    ae: float | None = None,
    length_scale_m: float | None = None,
    gamma: float | None = None,
    evo_time_s: float | None = None,
    factor1: float | None = None,
    lifetime: str | None = None,
    factor2: float | None = None,
) -> MannParams:
    """MannParams of ``preset`` at mean speed U [m/s]; explicit (non-None) arguments override the preset.

    Unless ``ae`` is given, alpha*eps^(2/3) is re-derived so that the model sigma_u equals the
    IEC NTM sigma_1 = Iref (0.75 U + 5.6) of the preset's class (Guo et al. 2023, Sect. 2.4): the run
    mapping of :func:`mann_run_keys` resolved by MannRun.from_mapping, as ``turbgen mann --preset``
    and the sweep do.

    Parameters
    ----------
    preset : str or StabilityPreset
        Preset name (built-in or in ``user``) or the preset itself.
    U_m_s : float
        Mean wind speed U [m/s], in [0.5, 100].
    user : Mapping of str to StabilityPreset, optional
        User presets (see :func:`get_preset`).
    ae, length_scale_m, gamma, evo_time_s, factor1, lifetime, factor2 : optional
        Overrides: ae [m^(4/3) s^-2], L [m], Gamma [-], gamma [s], factor1/2 [-], lifetime model.

    Returns
    -------
    MannParams

    Raises
    ------
    ParameterError
        For an unknown preset, one without Mann parameters, or a value outside its range.
    """
    given = {"ae": ae, "length_scale_m": length_scale_m, "gamma": gamma, "evo_time_s": evo_time_s,
             "factor1": factor1, "lifetime": lifetime, "factor2": factor2}
    mapping = {**mann_run_keys(preset, user=user), "U_m_s": U_m_s}
    mapping.update({key: v for key, v in given.items() if v is not None})
    return MannRun.from_mapping(mapping).params


def kaimal_settings_for(
    preset: str | StabilityPreset,
    U_m_s: float,
    *,
    user: Mapping[str, StabilityPreset] | None = None,
    sigma_m_s: tuple[float, float, float] | None = None,
    length_scales_m: tuple[float, float, float] | None = None,
    a_yz: float | None = None,
    lc_m: float | None = None,
    a_x: float | None = None,
    b_x: float | None = None,
) -> KaimalSettings:
    """Kaimal parameters of ``preset`` at mean speed U [m/s]; explicit arguments override the preset.

    sigma_1 = Iref (0.75 U + 5.6) (IEC class of the preset), sigma_2,3 = sigma_1 x preset ratios;
    the longitudinal model is the exponential Eq. 18 with the preset's Table 2 a_x, b_x.

    Parameters
    ----------
    preset : str or StabilityPreset
        Preset name (built-in or in ``user``) or the preset itself.
    U_m_s : float
        Mean wind speed U [m/s], in [0.5, 100].
    user : Mapping of str to StabilityPreset, optional
        User presets (see :func:`get_preset`).
    sigma_m_s, length_scales_m, a_yz, lc_m, a_x, b_x : optional
        Overrides: sigmas [m/s], L1..L3 [m], a_yz [-], Lc [m], a_x [-], b_x [1/m].

    Returns
    -------
    KaimalSettings

    Raises
    ------
    ParameterError
        For an unknown preset, one without Kaimal parameters, or a value outside its range.
    """
    p = _resolve(preset, user)
    if p.kaimal is None:
        raise ParameterError(f"preset {p.name!r} has no Kaimal parameters")
    k = p.kaimal
    if sigma_m_s is None:
        s1 = iec_sigma1_m_s(check_wind_speed(U_m_s), p.turb_class)
        sigma_m_s = tuple(r * s1 for r in k.sigma_ratios)
    params = KaimalParams(
        sigma_m_s=tuple(sigma_m_s),
        length_scales_m=k.length_scales_m if length_scales_m is None else tuple(length_scales_m),
        a_yz=k.a_yz if a_yz is None else a_yz,
        lc_m=k.lc_m if lc_m is None else lc_m,
    )
    return KaimalSettings(params, "exp", k.a_x if a_x is None else a_x, k.b_x if b_x is None else b_x)


def mann_run_keys(preset: str | StabilityPreset, *, user: Mapping[str, StabilityPreset] | None = None) -> dict:
    """The keys of a Mann run mapping (turbgen.spec.mann.MannRun.from_mapping) that ``preset`` sets.

    length_scale_m, gamma, evo_time_s, factor1, lifetime and turb_class: the run derives ae from
    the model variance for the class's sigma_1 at its U (the same ae as :func:`mann_params_for`).
    Used by ``turbgen mann --preset`` and by the sweep, so both build the same run.

    Parameters
    ----------
    preset : str or StabilityPreset
        Preset name (built-in or in ``user``) or the preset itself.
    user : Mapping of str to StabilityPreset, optional
        User presets (see :func:`get_preset`).

    Returns
    -------
    dict

    Raises
    ------
    ParameterError
        For an unknown preset or one without Mann parameters.
    """
    p = _resolve(preset, user)
    if p.mann is None:
        raise ParameterError(f"preset {p.name!r} has no Mann parameters")
    m = p.mann
    return {
        "length_scale_m": m.length_scale_m,
        "gamma": m.gamma,
        "evo_time_s": m.evo_time_s,
        "factor1": m.factor1,
        "lifetime": m.lifetime,
        "turb_class": p.turb_class,
    }


def kaimal_run_keys(
    preset: str | StabilityPreset,
    U_m_s: float,
    *,
    user: Mapping[str, StabilityPreset] | None = None,
    turb_class: str | None = None,
) -> dict:
    """The keys of a Kaimal run mapping (turbgen.spec.kaimal.KaimalRun.from_mapping) that ``preset`` sets.

    sigma_m_s, length_scales_m, a_yz, lc_m, long_model, a_x, b_x; ``turb_class`` (default: the
    preset's) sets sigma_1. Used by ``turbgen kaimal --preset`` and by the sweep, so both build
    the same run.

    Parameters
    ----------
    preset : str or StabilityPreset
        Preset name (built-in or in ``user``) or the preset itself.
    U_m_s : float
        Mean wind speed U [m/s], in [0.5, 100].
    user : Mapping of str to StabilityPreset, optional
        User presets (see :func:`get_preset`).
    turb_class : str, optional
        IEC class overriding the preset's.

    Returns
    -------
    dict

    Raises
    ------
    ParameterError
        For an unknown preset or class, one without Kaimal parameters, or U outside its range.
    """
    p = _resolve(preset, user)
    if turb_class is not None:
        p = replace(p, turb_class=turb_class)
    s = kaimal_settings_for(p, U_m_s)
    return {
        "sigma_m_s": list(s.kaimal.sigma_m_s),
        "length_scales_m": list(s.kaimal.length_scales_m),
        "a_yz": s.kaimal.a_yz,
        "lc_m": s.kaimal.lc_m,
        "long_model": s.long_model,
        "a_x": s.a_x,
        "b_x": s.b_x,
    }


def run_keys(model: str, preset: str | StabilityPreset, U_m_s: float, *,
             user: Mapping[str, StabilityPreset] | None = None, turb_class: str | None = None) -> dict:
    """The run-mapping keys ``preset`` sets for ``model`` ("mann" or "kaimal") at U [m/s].

    :func:`mann_run_keys` or :func:`kaimal_run_keys` (``turb_class`` overrides a Kaimal preset's class).

    Parameters
    ----------
    model : {"mann", "kaimal"}
        The model.
    preset, U_m_s, user, turb_class : optional
        As :func:`kaimal_run_keys` (U [m/s]); Mann uses ``preset`` and ``user`` only.

    Returns
    -------
    dict

    Raises
    ------
    ParameterError
        For a model without presets, or as :func:`mann_run_keys` / :func:`kaimal_run_keys`.
    """
    if model == "mann":
        return mann_run_keys(preset, user=user)
    if model == "kaimal":
        return kaimal_run_keys(preset, U_m_s, user=user, turb_class=turb_class)
    raise ParameterError(f"model = {model!r} has no presets")


__all__ = [
    "BUILTIN_PRESETS",
    "REFERENCE_U_M_S",
    "KaimalPreset",
    "KaimalSettings",
    "MannPreset",
    "StabilityPreset",
    "get_preset",
    "kaimal_run_keys",
    "mann_run_keys",
    "kaimal_settings_for",
    "load_presets",
    "mann_params_for",
    "preset_from_mapping",
    "run_keys",
    "presets_from_mapping",
    ]
