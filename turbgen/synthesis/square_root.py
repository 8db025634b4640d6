"""The principal square root of symmetric positive semi-definite matrices: the factor of every dense covariance.

Cholesky needs C > 0 and V sqrt(Lambda) flips column signs with the last bit (another field on another CPU); the
principal root is unique and Hölder continuous (Bhatia 1997, Thm. X.1.1), so rounding moves it by round-off only."""

from __future__ import annotations

import numpy as np


def principal_sqrt(c: np.ndarray) -> tuple[np.ndarray, float]:
    """(root, clipped): principal square roots V sqrt(max(Lambda, 0)) V^T of symmetric float64 (..., n, n) matrices, and
    max |Lambda_neg| over them (the spectral norm of C - root @ root; 0 when every C >= 0)."""
    lam, vec = np.linalg.eigh(c)
    root = (vec * np.sqrt(np.clip(lam, 0.0, None))[..., None, :]) @ np.swapaxes(vec, -1, -2)
    return root, float(max(-lam.min(), 0.0)) if lam.size else 0.0
