"""Compiled copy of the Mann generator's cropped yz-transformed slabs into its (y z point, k1) pencils: one pass
over the batch writing b consecutive complex numbers per pencil (numpy assigned slab by slab: b passes)."""

from __future__ import annotations

import numba


@numba.njit(nogil=True, cache=True)
def crop_into_pencils(uhat, ny, nz, spectra, j0):
    """spectra[c, y nz + z, j0 + j] = uhat[j, c, y, z] for y < ny, z < nz: the cropped pencils of b slabs."""
    b = uhat.shape[0]
    for c in range(3):
        for y in range(ny):
            for z in range(nz):
                row = spectra[c, y * nz + z]
                for j in range(b):
                    row[j0 + j] = uhat[j, c, y, z]


@numba.njit(nogil=True, cache=True)
def gather_points(uhat, iy, iz, spectra, j0):
    """spectra[c, p, j0 + j] = uhat[j, c, iy[p], iz[p]]: the pencils of the points (iy, iz) only (of b slabs)."""
    b = uhat.shape[0]
    for c in range(3):
        for p in range(len(iy)):
            row = spectra[c, p]
            for j in range(b):
                row[j0 + j] = uhat[j, c, iy[p], iz[p]]
