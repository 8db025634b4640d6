"""Spectral theory of the Mann (space-time) and Kaimal/IEC models: pure functions, SI units.

Modules
-------
params            frozen parameter dataclasses (validated in one place)
eddy_lifetime     Mann lifetime (Eq. 4), Guo lifetime (Eq. 6-7), evolution lifetime (Eq. 15)
mann_tensor       von Karman spectrum, sheared tensor Phi_ij and its square-root factor
kaimal            IEC 61400-1 Kaimal spectra and NTM parameters (Eq. 11)
coherence_models  yz exponential (Eq. 12), longitudinal exponential (Eq. 18), Simley-Pao, Kristensen
mann_spectra      one-point and cross-spectra F_ij(k1, dy, dz) by quadrature (Eq. 8-10), variances, ae for sigma_u
mann_quadrature   the (k2, k3) quadrature of Eq. 8: radial nodes, angular integrals of the sheared tensor
space_time        space-time tensor Theta (Eq. 13) and longitudinal coherence (Eq. 16)
rotor_effective   rotor-effective wind speed spectra (Eq. 24 Mann, Eq. 25 Kaimal)
lattice           line frequencies, pair weights, box wavenumbers and the Gauss rule of its cells
lidar_geometry    lidar beam geometry in the store frame: directions, focus points, measurements
lidar_weighting   probe-volume weighting along the beam (pulsed Gaussian, continuous-wave) and its transform
lidar_preview     REWS, lidar and lidar-rotor spectra, gamma^2_RL (Guo et al. 2023 Eq. 29-35)
lidar_lattice     the (k2, k3) lattice of a periodic synthesis box as the lidar spectra's quadrature
lidar_control     cut-off of ``|G_RL|``, coherence bandwidth, filter delay, buffer time (Fu et al. 2023)
lidar_los         line-of-sight spectra (Kaimal) and the lidar TI correction
ranges            allowed ranges of the inputs
fitting           Kaimal spectra (Eq. 20), yz coherence (Eq. 21) and exponential longitudinal coherence (Eq. 22) fits

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
