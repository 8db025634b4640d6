"""Preview quality of a lidar for a turbulence model: the theory behind `turbgen theory lidar`.

The lidar-rotor spectra of ``turbgen.theory.lidar_preview`` for a stability preset (Guo et al. 2023 Table 1/2)
and the design numbers they give."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from turbgen.errors import check_choice
from turbgen.virtual_lidar.description import LidarDescription
from turbgen.spec.models import DECLARATIONS, declaration, resolve
from turbgen.spec.preset_runs import kaimal_settings_for, mann_params_for
from turbgen.theory.coherence_models import exponential_longitudinal
from turbgen.theory.lidar_control import buffer_time_s, coherence_bandwidth_rad_m, cutoff_frequency_hz, filter_delay_s
from turbgen.theory.lidar_lattice import BoxLattice
from turbgen.theory.lidar_preview import PreviewSpectra, kaimal_preview_spectra, mann_preview_spectra
from turbgen.theory.params import KaimalParams, MannParams

MODELS = tuple(d.name for d in DECLARATIONS if d.preview is not None)  # the models with a preview theory
DEFAULT_F_HZ = np.geomspace(0.005, 0.3, 60)


def preview_spectra(model: str, lidar: LidarDescription, U_m_s: float, *, preset: str = "neutral",
                    f_hz=DEFAULT_F_HZ, radius_m: float | None = None, frozen: bool = False,
                    **options) -> PreviewSpectra:
    """S_RR, S_LL, S_RL of ``lidar`` at ``f_hz`` [Hz] for the preset's model parameters at ``U_m_s`` [m/s]; ``radius_m``
    [m] defaults to the lidar's rotor; ``frozen``: no eddy lifetime (Kaimal: a_x = b_x = 0); ``**options`` go to the
    model's preview. ParameterError for an unknown model or preset, U out of range, non-positive frequencies, or a beam
    not looking upstream."""
    check_choice("model", model, MODELS)
    R = lidar.rotor_radius_m if radius_m is None else radius_m
    preview = resolve(declaration(model).preview, "virtual_lidar")
    return preview(lidar, U_m_s, preset=preset, f_hz=f_hz, radius_m=R, frozen=frozen, **options)


def mann_preview(lidar: LidarDescription, U_m_s: float, *, preset: str, f_hz, radius_m: float, frozen: bool,
                 mann: MannParams | None = None, box: BoxLattice | None = None) -> PreviewSpectra:
    """The Mann model's ``preview``; with ``box`` the sum runs over that box's (k2, k3) lattice."""
    params = mann if mann is not None else mann_params_for(preset, U_m_s)
    if frozen:
        params = replace(params, evo_time_s=None)
    return mann_preview_spectra(f_hz, lidar.measurement_points(), params, U_m_s, radius_m, box=box)


def kaimal_preview(lidar: LidarDescription, U_m_s: float, *, preset: str, f_hz, radius_m: float, frozen: bool,
                   kaimal: KaimalParams | None = None, a_x: float | None = None, b_x: float | None = None,
                   long_components: str = "uvw", vw_coherence: bool = True, spectra=None,
                   yz_coherence=None) -> PreviewSpectra:
    """The Kaimal model's ``preview``; by default both coherences act on all components (Guo et al. 2023 Eq. 31/33)."""
    settings = kaimal_settings_for(preset, U_m_s)
    kp = kaimal if kaimal is not None else settings.kaimal
    ax = settings.a_x if a_x is None else a_x
    bx = settings.b_x if b_x is None else b_x
    if frozen:
        ax, bx = 0.0, 0.0

    def long_coherence(dx_m, f):
        return exponential_longitudinal(dx_m, f, U_m_s, ax, bx)

    return kaimal_preview_spectra(f_hz, lidar.measurement_points(), kp, U_m_s, radius_m, long_coherence,
                                  long_components=long_components, vw_coherence=vw_coherence, spectra=spectra,
                                  yz_coherence=yz_coherence)


def summarise(spectra: PreviewSpectra, lidar: LidarDescription, U_m_s: float, *,
              pitch_delay_s: float = 0.0, f_delay_hz: float = 0.025) -> dict:
    """The design numbers of a lidar, JSON-ready (non-finite values as None)."""
    f = spectra.f_hz
    cutoff = cutoff_frequency_hz(f, spectra.G_RL)
    k05 = coherence_bandwidth_rad_m(f, spectra.coh2_RL, U_m_s)
    out = {"f": f.tolist(), "coh2_RL": spectra.coh2_RL.tolist(), "G_RL": spectra.G_RL.tolist(), "k05_rad_m": k05,
           "cutoff_hz": cutoff, "d_eddy_min_m": 2.0 * np.pi / k05 if np.isfinite(k05) and k05 > 0 else float("nan"),
           "scan_time_s": lidar.scan_time_s}
    out = {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in out.items()}
    if np.isfinite(cutoff):
        out["filter_delay_s"] = filter_delay_s(cutoff, f_delay_hz)
        out["buffer_time_s"] = buffer_time_s(min(lidar.ranges_m), U_m_s, lidar.scan_time_s, cutoff,
                                             pitch_delay_s, f_delay_hz)
    return out
