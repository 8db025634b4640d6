"""What a stability preset (turbgen.spec.presets) gives each model's run at a mean wind speed.

The run keys ``--preset``, sweeps and the service merge, so all build the same run. ``preset`` is a name
(built-in or in ``user``: turbgen.spec.presets.get_preset) or a StabilityPreset; U_m_s [m/s]. Unknown presets,
presets without the model's parameters and values outside their ranges raise ParameterError."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from turbgen.errors import ParameterError
from turbgen.spec.mann import MannRun
from turbgen.spec.models import declaration, resolve
from turbgen.spec.presets import KaimalSettings, StabilityPreset, get_preset
from turbgen.theory.kaimal import iec_sigma1_m_s
from turbgen.theory.params import KaimalParams, MannParams, check_wind_speed


def _resolve(preset: str | StabilityPreset, user) -> StabilityPreset:
    return preset if isinstance(preset, StabilityPreset) else get_preset(preset, user)


def mann_params_for(preset: str | StabilityPreset, U_m_s: float, *, user: Mapping[str, StabilityPreset] | None = None,
                    ae: float | None = None, length_scale_m: float | None = None, gamma: float | None = None,
                    evo_time_s: float | None = None, factor1: float | None = None, lifetime: str | None = None,
                    factor2: float | None = None) -> MannParams:
    """MannParams of ``preset`` at U_m_s; explicit (non-None) arguments override the preset. Unless ``ae`` is given,
    the model sigma_u is the IEC NTM sigma_1 = Iref (0.75 U + 5.6) of the preset's class (Guo et al. 2023, Sect.
    2.4), as MannRun.from_mapping resolves :func:`mann_run_keys`."""
    given = {"ae": ae, "length_scale_m": length_scale_m, "gamma": gamma, "evo_time_s": evo_time_s,
             "factor1": factor1, "lifetime": lifetime, "factor2": factor2}
    mapping = {**mann_run_keys(preset, user=user), "U_m_s": U_m_s}
    mapping.update({key: v for key, v in given.items() if v is not None})
    return MannRun.from_mapping(mapping).params


def kaimal_settings_for(preset: str | StabilityPreset, U_m_s: float, *,
                        user: Mapping[str, StabilityPreset] | None = None,
                        sigma_m_s: tuple[float, float, float] | None = None,
                        length_scales_m: tuple[float, float, float] | None = None, a_yz: float | None = None,
                        lc_m: float | None = None, a_x: float | None = None,
                        b_x: float | None = None) -> KaimalSettings:
    """KaimalSettings of ``preset`` at U_m_s; explicit arguments override the preset. sigma_1 = Iref (0.75 U + 5.6)
    (the preset's class), sigma_2,3 = sigma_1 x its ratios; Eq. 18 with its Table 2 a_x, b_x (Guo et al. 2023)."""
    p = _resolve(preset, user)
    if p.kaimal is None:
        raise ParameterError(f"preset {p.name!r} has no Kaimal parameters")
    k = p.kaimal
    if sigma_m_s is None:
        s1 = iec_sigma1_m_s(check_wind_speed(U_m_s), p.turb_class)
        sigma_m_s = tuple(r * s1 for r in k.sigma_ratios)
    params = KaimalParams(tuple(sigma_m_s), k.length_scales_m if length_scales_m is None else tuple(length_scales_m),
                          k.a_yz if a_yz is None else a_yz, k.lc_m if lc_m is None else lc_m)
    return KaimalSettings(params, "exp", k.a_x if a_x is None else a_x, k.b_x if b_x is None else b_x)


def mann_run_keys(preset: str | StabilityPreset, U_m_s: float | None = None, *,
                  user: Mapping[str, StabilityPreset] | None = None, turb_class: str | None = None) -> dict:
    """The keys of a Mann run mapping that ``preset`` sets: length_scale_m, gamma, evo_time_s, factor1, lifetime and
    turb_class (``turb_class`` overrides the preset's); the run derives ae for the class's sigma_1 at its U, as
    :func:`mann_params_for`, so ``U_m_s`` is not used (it is in every model's preset-keys signature)."""
    p = _resolve(preset, user) if turb_class is None else replace(_resolve(preset, user), turb_class=turb_class)
    if p.mann is None:
        raise ParameterError(f"preset {p.name!r} has no Mann parameters")
    m = p.mann
    return {"length_scale_m": m.length_scale_m, "gamma": m.gamma, "evo_time_s": m.evo_time_s, "factor1": m.factor1,
            "lifetime": m.lifetime, "turb_class": p.turb_class}


def kaimal_run_keys(preset: str | StabilityPreset, U_m_s: float, *, user: Mapping[str, StabilityPreset] | None = None,
                    turb_class: str | None = None) -> dict:
    """The keys of a Kaimal run mapping that ``preset`` sets at U_m_s: sigma_m_s, length_scales_m, a_yz, lc_m,
    long_model, a_x, b_x (``turb_class`` overrides the preset's class, which sets sigma_1)."""
    p = _resolve(preset, user)
    if turb_class is not None:
        p = replace(p, turb_class=turb_class)
    s = kaimal_settings_for(p, U_m_s)
    return {"sigma_m_s": list(s.kaimal.sigma_m_s), "length_scales_m": list(s.kaimal.length_scales_m),
            "a_yz": s.kaimal.a_yz, "lc_m": s.kaimal.lc_m, "long_model": s.long_model, "a_x": s.a_x, "b_x": s.b_x}


def run_keys(model: str, preset: str | StabilityPreset, U_m_s: float, *,
             user: Mapping[str, StabilityPreset] | None = None, turb_class: str | None = None) -> dict:
    """The run-mapping keys ``preset`` sets for ``model``: its declaration's ``presets`` (turbgen.spec.models;
    ParameterError for a model without)."""
    reference = declaration(model).presets
    if reference is None:
        raise ParameterError(f"model = {model!r} has no presets")
    return resolve(reference, "spec")(preset, U_m_s, user=user, turb_class=turb_class)

