"""Default store names: a digest of everything that determines a field, for names that must not collide."""

from __future__ import annotations

import hashlib
import json

from turbgen.grid import Grid


def run_digest(parameters: dict, grid: Grid) -> str:
    """8 hex digits of SHA-256 over the run's parameters (JSON; others as ``str``) and grid."""
    doc = {"parameters": parameters, "grid": {"nt": grid.nt, "dt_s": grid.dt_s, "x_m": list(grid.x_m),
                                              "ny": grid.ny, "nz": grid.nz, "dy_m": grid.dy_m, "dz_m": grid.dz_m}}
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()[:8]
