"""What a stability preset (turbgen.spec.presets) gives each model's run at a mean wind speed:
Mann parameters, Kaimal settings, and the run keys the CLI, sweeps and the service merge.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from turbgen.errors import ParameterError
from turbgen.spec.mann import MannRun
from turbgen.spec.presets import KaimalSettings, StabilityPreset, get_preset
from turbgen.theory.kaimal import iec_sigma1_m_s
from turbgen.theory.params import KaimalParams, MannParams, check_wind_speed


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

