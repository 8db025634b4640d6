"""Lidar beam geometry in turbgen's frame.

The frame is the field store's: x upstream from the rotor plane (the lidar at the hub, x = y = z = 0),
y to the left looking downwind, z up from hub height; (u, v, w) with u downwind (towards -x). A beam
of direction d measures v_los = n . (u, v, w), n = (d_x, -d_y, -d_z), *positive towards the lidar*
(Guo et al. 2023, Eq. 26 with x downwind; Fu et al. 2023, Eq. 10 writes n_1 = -cos phi with x upstream
and the opposite sign), so a beam looking straight upstream measures +u and the rotor-effective
estimate, each measurement divided by its n_1 (Guo et al. 2023, Eq. 28), gives u for a uniform u."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError


def nacelle_directions(azimuth_deg, elevation_deg) -> np.ndarray:
    """Beam directions d = (cos beta cos phi, cos beta sin phi, sin beta) of a nacelle lidar (Guo et al. 2023, Fig. 3);
    ``azimuth_deg`` phi (towards +y) and ``elevation_deg`` beta (up) [deg] per beam, of equal shape (else
    ParameterError); returns (n_beams, 3) unit vectors (x upstream, y, z)."""
    phi = np.radians(np.atleast_1d(np.asarray(azimuth_deg, dtype=float)))
    beta = np.radians(np.atleast_1d(np.asarray(elevation_deg, dtype=float)))
    if phi.shape != beta.shape:
        raise ParameterError("azimuth_deg and elevation_deg need the same number of beams")
    return np.stack([np.cos(beta) * np.cos(phi), np.cos(beta) * np.sin(phi), np.sin(beta)], axis=-1)


def spinner_directions(half_cone_deg: float, scan_deg, tilt_deg: float = 0.0) -> np.ndarray:
    """Beam directions d of a spinner lidar (Fu et al. 2023, Eq. 10-12).

    d = cos phi a + sin phi (cos theta e_y + sin theta e_perp), a = (cos tilt, 0, sin tilt),
    e_perp = (-sin tilt, 0, cos tilt): the cone around the shaft, tilted up with it (about y).

    ``half_cone_deg`` phi, ``scan_deg`` theta (from +y towards +z) and ``tilt_deg`` in degrees; returns one unit
    vector (x upstream, y, z) per scan angle."""
    phi = np.radians(float(half_cone_deg))
    theta = np.radians(np.atleast_1d(np.asarray(scan_deg, dtype=float)))
    tilt = np.radians(float(tilt_deg))
    axis = np.array([np.cos(tilt), 0.0, np.sin(tilt)])
    e_y = np.array([0.0, 1.0, 0.0])
    e_perp = np.array([-np.sin(tilt), 0.0, np.cos(tilt)])
    return (np.cos(phi) * axis[None, :]
            + np.sin(phi) * (np.cos(theta)[:, None] * e_y[None, :] + np.sin(theta)[:, None] * e_perp[None, :]))


def los_vectors(directions) -> np.ndarray:
    """Line-of-sight vectors n = (d_x, -d_y, -d_z) [-] of (..., 3) beam directions (module docstring)."""
    d = np.asarray(directions, dtype=float)
    return d * np.array([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class Measurements:
    """Where and how a lidar measures, one row per measurement (beam x range gate): (M, 3) LOS vectors ``n``, unit
    beam directions (x upstream, y, z) and focus points from the hub [m]; (M, K) probe-volume offsets along the beam
    [m] and weights (rows sum to 1); (M,) beam and gate indices."""

    n: np.ndarray
    focus_m: np.ndarray
    direction: np.ndarray
    offsets_m: np.ndarray
    weights: np.ndarray
    beam: np.ndarray
    gate: np.ndarray

    @property
    def count(self) -> int:
        """Number of measurements M."""
        return int(self.n.shape[0])

    def sample_points_m(self) -> np.ndarray:
        """(M, K, 3) probe-volume points focus + offset * direction [m] relative to the hub."""
        return self.focus_m[:, None, :] + self.offsets_m[..., None] * self.direction[:, None, :]

    def subset(self, rows) -> "Measurements":
        """The Measurements of ``rows`` (integer indices or a boolean mask of length M)."""
        rows = np.asarray(rows)
        return Measurements(*(getattr(self, f)[rows] for f in
                              ("n", "focus_m", "direction", "offsets_m", "weights", "beam", "gate")))
