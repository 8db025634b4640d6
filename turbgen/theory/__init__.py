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
lattice           line frequencies, pair weights and box wavenumbers of the periodic record/box
lidar_geometry    lidar beam geometry in the store frame: directions, focus points, measurements
lidar_weighting   probe-volume weighting along the beam (pulsed Gaussian, continuous-wave) and its transform
lidar_preview     REWS, lidar and lidar-rotor spectra, gamma^2_RL (Guo et al. 2023 Eq. 29-35)
lidar_lattice     the (k2, k3) lattice of a periodic synthesis box as the lidar spectra's quadrature
lidar_control     cut-off of |G_RL|, coherence bandwidth, filter delay, buffer time (Fu et al. 2023)
lidar_los         line-of-sight spectra (Kaimal) and the lidar TI correction
ranges            allowed ranges of the inputs
fitting           Kaimal spectra (Eq. 20), yz coherence (Eq. 21) and exponential longitudinal coherence (Eq. 22) fits
"""
