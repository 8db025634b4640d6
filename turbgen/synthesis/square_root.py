"""The principal square root of symmetric positive semi-definite matrices: the factor of every dense covariance.

A factor F with F F^T = C turns standard normals into a sample of covariance C. Cholesky's F exists only while C is
numerically positive definite, and the eigenvector factor V sqrt(Lambda) flips its columns' signs (or rotates them
inside a degenerate eigenspace) when an entry that is zero in exact arithmetic changes sign in its last bit -- i.e.
with the CPU's SIMD kernels. Either way the same seed would name another field on another machine. The principal
root sqrt(C) = V sqrt(Lambda) V^T is unique for any C >= 0 and Hölder continuous,
||sqrt(A) - sqrt(B)|| <= ||A - B||^(1/2) in the spectral norm (Bhatia 1997, "Matrix Analysis", Thm. X.1.1 with
f(t) = t^(1/2)), so a rounding of C moves it by round-off only, whatever the conditioning of C.
"""

from __future__ import annotations

import numpy as np


def principal_sqrt(c: np.ndarray) -> tuple[np.ndarray, float]:
    """(root, clipped): principal square roots V sqrt(max(Lambda, 0)) V^T of symmetric float64 (..., n, n) matrices, and
    max |Lambda_neg| over them (the spectral norm of C - root @ root; 0 when every C >= 0).
    """
    lam, vec = np.linalg.eigh(c)
    root = (vec * np.sqrt(np.clip(lam, 0.0, None))[..., None, :]) @ np.swapaxes(vec, -1, -2)
    return root, float(max(-lam.min(), 0.0)) if lam.size else 0.0
