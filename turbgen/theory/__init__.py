"""Spectral theory of the Mann (space-time) and Kaimal/IEC models: pure functions, SI units.

Modules
-------
params            frozen parameter dataclasses (validated in one place)
eddy_lifetime     Mann lifetime (Eq. 4), Guo lifetime (Eq. 6-7), evolution lifetime (Eq. 15)
mann_tensor       von Karman spectrum, sheared tensor Phi_ij and its square-root factor
kaimal            IEC 61400-1 Kaimal spectra and NTM parameters (Eq. 11)
coherence_models  yz exponential (Eq. 12), longitudinal exponential (Eq. 18), Simley-Pao, Kristensen
"""
