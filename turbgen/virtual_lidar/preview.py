"""Preview quality of a lidar for a turbulence model: the theory behind `turbgen theory lidar`.

Evaluates the lidar-rotor spectra of ``turbgen.theory.lidar_preview`` for a stability preset (Guo et al.
2023 Table 1/2) at a mean wind speed and summarises what a lidar-assisted-control design needs: gamma^2_RL,
|G_RL|, its -3 dB cut-off, the coherence bandwidth k_0.5 and d_eddy,min, the filter delay and buffer time.
"""

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
    """S_RR, S_LL, S_RL of ``lidar`` at ``f_hz`` for the preset's model parameters at U (or explicit ones).

    Parameters
    ----------
    model, lidar, U_m_s : str, LidarDescription, float
        One of :data:`MODELS` (its ``preview`` in turbgen.spec.models is called), the lidar, mean wind speed [m/s].
    preset : str, optional
        Stability preset giving the model parameters at U (default "neutral").
    f_hz : array_like, optional
        Frequencies [Hz] (> 0); default 60 log-spaced from 0.005 to 0.3 Hz.
    radius_m : float, optional
        Rotor radius R [m]; default the lidar's ``rotor_radius_m``.
    frozen : bool, optional
        Frozen turbulence (Mann: no eddy lifetime; Kaimal: a_x = b_x = 0).
    **options
        The model's own keywords (:func:`mann_preview`, :func:`kaimal_preview`).

    Raises
    ------
    ParameterError
        For an unknown model or preset, a wind speed out of range, non-positive frequencies, or a beam that
        does not look upstream.
    """
    check_choice("model", model, MODELS)
    R = lidar.rotor_radius_m if radius_m is None else radius_m
    preview = resolve(declaration(model).preview, "virtual_lidar")
    return preview(lidar, U_m_s, preset=preset, f_hz=f_hz, radius_m=R, frozen=frozen, **options)


def mann_preview(lidar: LidarDescription, U_m_s: float, *, preset: str, f_hz, radius_m: float, frozen: bool,
                 mann: MannParams | None = None, box: BoxLattice | None = None) -> PreviewSpectra:
    """The Mann model's ``preview``: ``lidar_preview.mann_preview_spectra`` (arguments as :func:`preview_spectra`).

    ``mann`` replaces the preset's parameters; with ``box`` the sum runs over that periodic box's (k2, k3)
    lattice (what a synthesised box holds) instead of the continuous integral.
    """
    params = mann if mann is not None else mann_params_for(preset, U_m_s)
    if frozen:
        params = replace(params, evo_time_s=None)
    return mann_preview_spectra(f_hz, lidar.measurement_points(), params, U_m_s, radius_m, box=box)


def kaimal_preview(lidar: LidarDescription, U_m_s: float, *, preset: str, f_hz, radius_m: float, frozen: bool,
                   kaimal: KaimalParams | None = None, a_x: float | None = None, b_x: float | None = None,
                   long_components: str = "uvw", vw_coherence: bool = True, spectra=None,
                   yz_coherence=None) -> PreviewSpectra:
    """The Kaimal model's ``preview``: ``lidar_preview.kaimal_preview_spectra`` (arguments as :func:`preview_spectra`).

    Defaults follow Guo et al. (2023) Eq. 31/33 (Chen et al. 2022): the yz and longitudinal coherences act on all
    three components (``vw_coherence``, ``long_components``). ``kaimal`` and ``a_x``, ``b_x`` [-] (exponential
    longitudinal decay) replace the preset's values; ``spectra`` and ``yz_coherence`` (a store's LineSpectrum and
    LineCoherence) the Kaimal spectra and IEC coherence.
    """
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
    """The design numbers of a lidar, JSON-ready (non-finite values as None).

    ``f`` [Hz], ``coh2_RL``, ``G_RL`` [-], ``k05_rad_m`` [rad/m], ``cutoff_hz`` [Hz], ``d_eddy_min_m`` [m],
    ``scan_time_s`` [s], and where the cut-off exists ``filter_delay_s`` (taken at ``f_delay_hz``) and
    ``buffer_time_s`` [s] (with the pitch actuator delay ``pitch_delay_s`` [s]).
    """
    f = spectra.f_hz
    cutoff = cutoff_frequency_hz(f, spectra.G_RL)
    k05 = coherence_bandwidth_rad_m(f, spectra.coh2_RL, U_m_s)
    out = {
        "f": f.tolist(),
        "coh2_RL": spectra.coh2_RL.tolist(),
        "G_RL": spectra.G_RL.tolist(),
        "k05_rad_m": k05,
        "cutoff_hz": cutoff,
        "d_eddy_min_m": 2.0 * np.pi / k05 if np.isfinite(k05) and k05 > 0 else float("nan"),
        "scan_time_s": lidar.scan_time_s,
    }
    out = {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in out.items()}
    if np.isfinite(cutoff):
        out["filter_delay_s"] = filter_delay_s(cutoff, f_delay_hz)
        out["buffer_time_s"] = buffer_time_s(min(lidar.ranges_m), U_m_s, lidar.scan_time_s, cutoff,
                                             pitch_delay_s, f_delay_hz)
    return out
