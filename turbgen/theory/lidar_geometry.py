"""Lidar beam geometry in turbgen's frame.

The frame is the field store's: x is the upstream distance from the rotor plane (the lidar sits at
the hub, x = y = z = 0), y is to the left looking downwind, z is up from hub height. Velocities are
(u, v, w): u downwind (towards -x), v along +y, w up.

A beam leaves the lidar with direction d (unit vector in x, y, z). Its line-of-sight speed is taken
*positive towards the lidar*, so a beam looking straight upstream measures v_los = +u:

    v_los = n . (u, v, w),   n = (d_x, -d_y, -d_z)

(the sign convention of Guo et al. 2023 Eq. 26 with x downwind; Fu et al. 2023 Eq. 10 writes
n_1 = -cos phi for the same beam in a frame with x upstream and the opposite speed sign). The
lidar estimate of the rotor-effective wind speed divides each measurement by its n_1
(Guo et al. 2023 Eq. 28, Fu et al. 2023 Eq. 23), so u_LL = u for a uniform u.

Nacelle lidar (Guo et al. 2023 Fig. 3): azimuth phi (towards +y) and elevation beta (up),
d = (cos beta cos phi, cos beta sin phi, sin beta).
Spinner lidar (Fu et al. 2023 Eq. 10-12): half-cone angle phi around the shaft axis and scan angle
theta (from +y towards +z), the cone tilted up with the shaft by the tilt angle (a rotation about y):
d = cos phi a + sin phi (cos theta e_y + sin theta e_perp), a = (cos tilt, 0, sin tilt),
e_perp = (-sin tilt, 0, cos tilt).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError


def nacelle_directions(azimuth_deg, elevation_deg) -> np.ndarray:
    """Beam directions d of a nacelle lidar from azimuth and elevation (Guo et al. 2023 Fig. 3).

    d = (cos beta cos phi, cos beta sin phi, sin beta) in (x upstream, y, z).

    Parameters
    ----------
    azimuth_deg : array_like
        Azimuth phi of each beam, towards +y [deg].
    elevation_deg : array_like
        Elevation beta of each beam, up [deg]; as many values as ``azimuth_deg``.

    Returns
    -------
    numpy.ndarray
        (n_beams, 3) unit direction vectors [-].

    Raises
    ------
    ParameterError
        If ``azimuth_deg`` and ``elevation_deg`` differ in shape (number of beams).
    """
    phi = np.radians(np.atleast_1d(np.asarray(azimuth_deg, dtype=float)))
    beta = np.radians(np.atleast_1d(np.asarray(elevation_deg, dtype=float)))
    if phi.shape != beta.shape:
        raise ParameterError("azimuth_deg and elevation_deg need the same number of beams")
    return np.stack([np.cos(beta) * np.cos(phi), np.cos(beta) * np.sin(phi), np.sin(beta)], axis=-1)


def spinner_directions(half_cone_deg: float, scan_deg, tilt_deg: float = 0.0) -> np.ndarray:
    """Beam directions d of a spinner lidar: half-cone angle, scan angles, shaft tilt (Fu et al. 2023 Eq. 10-12).

    d = cos phi a + sin phi (cos theta e_y + sin theta e_perp), a = (cos tilt, 0, sin tilt),
    e_perp = (-sin tilt, 0, cos tilt), in (x upstream, y, z).

    Parameters
    ----------
    half_cone_deg : float
        Half-cone angle phi around the shaft axis [deg].
    scan_deg : array_like
        Scan angles theta, from +y towards +z [deg].
    tilt_deg : float, optional
        Shaft tilt, the cone tilted up (a rotation about y) [deg] (default 0).

    Returns
    -------
    numpy.ndarray
        (n_beams, 3) unit direction vectors [-], one row per scan angle.
    """
    phi = np.radians(float(half_cone_deg))
    theta = np.radians(np.atleast_1d(np.asarray(scan_deg, dtype=float)))
    tilt = np.radians(float(tilt_deg))
    axis = np.array([np.cos(tilt), 0.0, np.sin(tilt)])
    e_y = np.array([0.0, 1.0, 0.0])
    e_perp = np.array([-np.sin(tilt), 0.0, np.cos(tilt)])
    return (np.cos(phi) * axis[None, :]
            + np.sin(phi) * (np.cos(theta)[:, None] * e_y[None, :] + np.sin(theta)[:, None] * e_perp[None, :]))


def los_vectors(directions) -> np.ndarray:
    """Line-of-sight vectors n = (d_x, -d_y, -d_z): v_los = n . (u, v, w), positive towards the lidar.

    Sign convention of Guo et al. 2023 Eq. 26 with x downwind (module docstring).

    Parameters
    ----------
    directions : array_like
        (..., 3) beam directions d (x upstream, y, z) [-].

    Returns
    -------
    numpy.ndarray
        n [-], shaped like ``directions``.
    """
    d = np.asarray(directions, dtype=float)
    return d * np.array([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class Measurements:
    """Where and how a lidar measures, as arrays (one row per measurement = beam x range gate).

    Parameters
    ----------
    n : numpy.ndarray
        (M, 3) line-of-sight vectors [-], v_los = n . (u, v, w) (module docstring).
    focus_m : numpy.ndarray
        (M, 3) focus points (x upstream, y, z) [m] relative to the hub.
    direction : numpy.ndarray
        (M, 3) beam directions d (unit, x upstream, y, z) [-].
    offsets_m : numpy.ndarray
        (M, K) positions along the beam relative to the focus [m] (probe volume).
    weights : numpy.ndarray
        (M, K) probe-volume weights [-], each row summing to 1.
    beam : numpy.ndarray
        (M,) beam index of each measurement.
    gate : numpy.ndarray
        (M,) range-gate index of each measurement.
    """

    n: np.ndarray
    focus_m: np.ndarray
    direction: np.ndarray
    offsets_m: np.ndarray
    weights: np.ndarray
    beam: np.ndarray
    gate: np.ndarray

    @property
    def count(self) -> int:
        """Number of measurements M (rows: beam x range gate).

        Returns
        -------
        int
            M [-].
        """
        return int(self.n.shape[0])

    def sample_points_m(self) -> np.ndarray:
        """Points (x upstream, y, z) of the probe volume: focus + offset * direction.

        Returns
        -------
        numpy.ndarray
            (M, K, 3) points [m] relative to the hub.
        """
        return self.focus_m[:, None, :] + self.offsets_m[..., None] * self.direction[:, None, :]

    def subset(self, rows) -> "Measurements":
        """The measurements of the given rows (indices or boolean mask).

        Parameters
        ----------
        rows : array_like
            Integer indices or a boolean mask of length M.

        Returns
        -------
        Measurements
            A new Measurements with the selected rows of every field.
        """
        rows = np.asarray(rows)
        return Measurements(*(getattr(self, f)[rows] for f in
                              ("n", "focus_m", "direction", "offsets_m", "weights", "beam", "gate")))
