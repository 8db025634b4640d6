"""Field generators (no file I/O): they return or yield float32 arrays.

random_streams   counter-keyed complex Gaussian noise per (seed, snapshot, k1-slab)
sfc64            numpy's SFC64 seeded by SeedSequence(key), compiled
ziggurat_normals numpy's float32 Ziggurat normals of one keyed SFC64 stream, compiled
mann_stencil     Mann (1998) factor C(k) and 1/tau_e(k) of one parameter set and grid: one MannStencil, one
                 build_stencil (scaled or ae-free unit energy; in memory, on demand, or some slabs)
mann_factors     the stencil's per-slab factors from Mann (1994) Eq. 13-17, and their scaling to an energy level
mann_spacetime   Mann space-time snapshots (Guo et al. 2022): exact OU evolution of the Fourier noise
circulant        per-frequency yz coefficients of the Kaimal generator
kaimal_evo       Kaimal field with longitudinal coherence (evoTurb style)
"""
