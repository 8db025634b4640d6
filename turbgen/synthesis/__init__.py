"""Field generators (no file I/O): they return or yield float32 arrays.

Mann: mann_stencil (C(k), 1/tau_e(k)) -> mann_spacetime (Guo et al. 2022 snapshots); Kaimal: circulant (yz
sampling) -> kaimal_evo; conditioning on measurements: conditioning, kaimal_conditioning; noise: random_streams.
"""
