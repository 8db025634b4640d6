"""Spectral theory of the Mann (space-time) and Kaimal/IEC models: pure functions, SI units.

Modules
-------
params            frozen parameter dataclasses (validated in one place)
eddy_lifetime     Mann lifetime (Eq. 4), Guo lifetime (Eq. 6-7), evolution lifetime (Eq. 15)
mann_tensor       von Karman spectrum, sheared tensor Phi_ij and its square-root factor
kaimal            IEC 61400-1 Kaimal spectra and NTM parameters (Eq. 11)
coherence_models  yz exponential (Eq. 12), longitudinal exponential (Eq. 18), Simley-Pao, Kristensen
mann_spectra      one-point and cross-spectra F_ij(k1, dy, dz) by quadrature (Eq. 8-10), variances, ae for sigma_u
space_time        space-time tensor Theta (Eq. 13) and longitudinal coherence (Eq. 16)
rotor_effective   rotor-effective wind speed spectra (Eq. 24 Mann, Eq. 25 Kaimal)
lattice           line frequencies, pair weights and box wavenumbers of the periodic record/box
fitting           Kaimal spectra (Eq. 20), yz coherence (Eq. 21) and exponential longitudinal coherence (Eq. 22) fits
"""
