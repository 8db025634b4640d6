"""Spectral theory of the Mann (space-time) and Kaimal/IEC models: pure functions, SI units.

Modules (equations of Guo et al. 2023): Mann ``params``, ``eddy_lifetime`` (Eq. 4, 6-7, 15), ``mann_tensor``,
``mann_spectra`` (Eq. 8-10), ``mann_quadrature``, ``space_time`` (Eq. 13, 16); Kaimal/IEC ``kaimal`` (Eq. 11),
``coherence_models`` (Eq. 12, 18); ``rotor_effective`` (Eq. 24-25); the lidar's ``lidar_geometry``,
``lidar_weighting``, ``lidar_preview`` (Eq. 29-35), ``lidar_lattice``, ``lidar_control``, ``lidar_los``;
``lattice``, ``ranges``, ``fitting`` (Eq. 20-22) and ``sonic_path`` (a sonic anemometer's path averaging).

The main functions are also names of this package (``turbgen.theory.one_point_spectra``, ... : see ``__all__``),
each imported from its module on first use.

Examples
--------
>>> import numpy as np
>>> from turbgen import theory
>>> p = theory.MannParams(ae=0.1, length_scale_m=49.0, gamma=3.1, evo_time_s=400.0)
>>> F = theory.one_point_spectra([0.01, 0.1], p)        # two-sided F_ii(k1) [m^3 s^-2]
>>> np.round(F["F11"], 2)
array([24.71,  0.75])
>>> round(float(theory.variances(p)["uu"]), 3)           # sigma_u^2 [m^2 s^-2]
2.463
>>> np.round(theory.longitudinal_coherence([0.01, 0.05], 100.0, 16.0, p), 3)   # Eq. 16, dx 100 m
array([0.892, 0.559])
"""

import importlib

# The namespace of the pure functions, ``turbgen.theory.<name>`` (imported on first use, so importing one module of
# turbgen.theory does not import the others): name -> module of turbgen.theory
_NAMES = {
    "MannParams": "params", "KaimalParams": "params",
    "one_point_spectra": "mann_spectra", "cross_spectrum": "mann_spectra", "yz_coherence": "mann_spectra",
    "variances": "mann_spectra", "ae_for_sigma_u": "mann_spectra",
    "space_time_tensor": "space_time", "longitudinal_coherence": "space_time",
    "rews_spectrum_mann": "rotor_effective", "rews_spectrum_kaimal": "rotor_effective",
    "kaimal_spectrum": "kaimal", "iec_sigma1_m_s": "kaimal", "iec_kaimal_params": "kaimal",
    "exponential_yz": "coherence_models", "exponential_longitudinal": "coherence_models",
    "simley_pao": "coherence_models", "kristensen": "coherence_models",
    "fit_kaimal_spectra": "fitting", "fit_yz_coherence": "fitting", "fit_longitudinal": "fitting",
    "Measurements": "lidar_geometry", "mann_preview_spectra": "lidar_preview",
    "kaimal_preview_spectra": "lidar_preview", "cutoff_frequency_hz": "lidar_control",
    "coherence_bandwidth_rad_m": "lidar_control", "buffer_time_s": "lidar_control",
    "lidar_ti_correction": "lidar_los",
}  # fmt: skip
__all__ = sorted(_NAMES)


def __getattr__(name: str):
    if name in _NAMES:
        return getattr(importlib.import_module(f"turbgen.theory.{_NAMES[name]}"), name)
    raise AttributeError(f"module 'turbgen.theory' has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_NAMES})
