"""Virtual lidar: line-of-sight speeds sampled from a field store along the beams.

A measurement returns v_los = sum_k w_k n . (u, v, w)(p_k), p_k = focus + s_k d (frame: docs/store.md). Each point
of gate g's probe volume comes from gate g's own plane by Taylor's hypothesis (Guo et al. 2023, Sect. 5.1.2):
point x' at physical time T is the stored time T + x'/U (linear in t, bilinear in y, z)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from turbgen.errors import ParameterError, check_range

PLANE_TOL_M = 1e-6


def weighted_sum(values: np.ndarray, weights) -> np.ndarray:
    """sum_k values[..., k] weights[k] by numpy's pairwise sum: the same bits on every CPU and batch row (no BLAS)."""
    return np.add.reduce(np.asarray(values, float) * np.asarray(weights, float), axis=-1)


@dataclass(frozen=True)
class Measurement:
    """One beam-gate: unit projection ``n`` on (u, v, w), ``focus_m`` (x, y, z) [m], probe ``offsets_m`` [m] along
    ``direction`` with ``weights`` (>= 0, sum 1), ``plane_x_m`` the gate's plane [m] (default the focus x)."""

    beam: int
    gate: int
    n: tuple
    focus_m: tuple
    offsets_m: tuple = (0.0,)
    weights: tuple = (1.0,)
    direction: tuple | None = field(default=None)
    plane_x_m: float | None = None

    def points_m(self) -> np.ndarray:
        """Probe-volume points focus + offset * direction, (k, 3) in (x upstream, y, z) [m]."""
        f = np.asarray(self.focus_m, float)
        d = np.asarray(self.direction, float) if self.direction is not None else f / np.linalg.norm(f)
        return f[None, :] + np.asarray(self.offsets_m, float)[:, None] * d[None, :]


@dataclass(frozen=True)
class LidarSamples:
    """The sampled line-of-sight speeds: ``v_los`` float32 (n_scan, n_beam, n_gate) [m/s] positive towards the lidar,
    ``time_s`` (n_scan, n_beam) [s], the gates' planes and n_1, and the mean wind added (if any)."""

    v_los: np.ndarray
    time_s: np.ndarray
    gates_x_m: np.ndarray
    n1: np.ndarray
    mean_wind_added: bool
    shear_exponent: float
    mean_wind: str = ""
    mean_wind_record: dict | None = None


def _plane_index(grid, x: float, beam: int, gate: int) -> int:
    xs = grid.x()
    i = int(np.argmin(np.abs(xs - x)))
    if abs(xs[i] - x) <= PLANE_TOL_M * max(1.0, abs(x)):
        return i
    where = "beyond the store's planes" if x > xs.max() + PLANE_TOL_M else "between the store's planes"
    raise ParameterError(
        f"lidar gate {gate} of beam {beam} at x = {x:g} m is {where} (planes: "
        f"{', '.join(f'{v:g}' for v in xs)} m); gates must be planes of the store: make the field with a plane at "
        f"x = {x:g} m (`x_m`)"
    )


def check_measurements(fs, measurements) -> list[int]:
    """Check the measurements against store ``fs`` and return each one's plane index; ParameterError for bad weights, n
    not a unit vector, a gate not on a plane, or a point off the yz field."""
    g = fs.grid
    y, z = g.y(), g.z()
    planes = []
    for m in measurements:
        w = np.asarray(m.weights, float)
        s = np.asarray(m.offsets_m, float)
        n = np.asarray(m.n, float)
        if w.shape != s.shape or w.size == 0 or not np.all(np.isfinite(w)) or np.any(w < 0) or abs(w.sum() - 1) > 1e-6:
            raise ParameterError(
                f"lidar beam {m.beam} gate {m.gate}: probe-volume weights must be >= 0, one per offset, "
                f"summing to 1 (got sum {w.sum():g})"
            )
        if not np.all(np.isfinite(n)) or abs(np.linalg.norm(n) - 1) > 1e-6:
            raise ParameterError(f"lidar beam {m.beam}: n = {n.tolist()} is not a unit vector")
        px = float(m.focus_m[0]) if m.plane_x_m is None else float(m.plane_x_m)
        planes.append(_plane_index(g, px, m.beam, m.gate))
        p = m.points_m()
        for k, (lo, hi, name) in enumerate(((y[0], y[-1], "y"), (z[0], z[-1], "z"))):
            c = p[:, k + 1]
            if c.min() < lo - 1e-9 or c.max() > hi + 1e-9:
                bad = c.min() if c.min() < lo else c.max()
                raise ParameterError(
                    f"lidar beam {m.beam} leaves the yz field at gate x = {m.focus_m[0]:g} m: "
                    f"{name} = {bad:.4g} m is outside [{lo:g}, {hi:g}] m"
                )
        if p[:, 0].min() < -1e-9:
            raise ParameterError(f"lidar beam {m.beam} gate {m.gate}: probe volume reaches behind the rotor (x < 0)")
    return planes


def interp_axis(coord0: float, step: float, n: int, values: np.ndarray):
    """Lower index and fraction of linear interpolation on a regular axis of n nodes."""
    f = (values - coord0) / step
    f = np.where(np.abs(f - np.round(f)) <= 1e-9, np.round(f), f)  # a node within rounding is the node: the cell
    # (and the constrained runs' scan pattern) does not depend on how T + x/U rounds
    i = np.clip(np.floor(f).astype(np.int64), 0, max(n - 2, 0))
    return i, (np.zeros_like(f) if n == 1 else f - i)


def _corners(it, at, jy, ay, jz, az, shape):
    """The 8 corners of the points' (t, y, z) cells: (t, y, z indices clipped to ``shape``, trilinear weight)."""
    for dt_, wt in ((0, 1 - at), (1, at)):
        for dy_, wy in ((0, 1 - ay), (1, ay)):
            for dz_, wz in ((0, 1 - az), (1, az)):
                yield (np.minimum(it + dt_, shape[0] - 1), np.minimum(jy + dy_, shape[1] - 1),
                       np.minimum(jz + dz_, shape[2] - 1), wt * (wy * wz))


def _heights(hub_height_m: float, points_m: np.ndarray) -> np.ndarray:
    """Heights above the ground [m] of the probe points (k, 3); ParameterError if one is at or below it."""
    h = hub_height_m + points_m[:, 2]
    if np.any(h <= 0):
        raise ParameterError("lidar: a probe point lies below the ground; cannot add the mean wind")
    return h


def sample(fs, measurements, times_s, beam_of_sample, *, add_mean_wind: bool = False,
           shear_exponent: float = 0.2, mean_wind=None) -> LidarSamples:
    """Sample store ``fs`` with ``measurements`` at the physical times ``times_s`` [s], whole scans only;
    ``beam_of_sample``: one beam at a time in a repeating order. ``add_mean_wind``: the power law with
    ``shear_exponent`` [-] or ``mean_wind`` (as the exports apply it). ParameterError as :func:`check_measurements`, for
    a bad schedule, a store shorter than two scans, a shear exponent outside [-1, 1] or a point below ground."""
    shear_exponent = check_range("shear exponent", shear_exponent, -1.0, 1.0)  # the exports' range
    g, U = fs.grid, fs.U_m_s
    planes = check_measurements(fs, measurements)
    beams = sorted({m.beam for m in measurements})
    gates = sorted({m.gate for m in measurements})
    nb, ng = len(beams), len(gates)
    if len(measurements) != nb * ng:
        raise ParameterError(f"lidar: every beam needs every gate ({len(measurements)} measurements for {nb} x {ng})")
    times_s = np.asarray(times_s, float)
    beam_of_sample = np.asarray(beam_of_sample)
    order = beam_of_sample[:nb]
    if sorted(order.tolist()) != beams:
        raise ParameterError("lidar schedule: the first scan does not visit every beam once")
    # stored-time extent of every point: t = T + x'/U must lie within [0, t_end]
    x_max = max(m.points_m()[:, 0].max() for m in measurements)
    t_end = (g.nt - 1) * g.dt_s
    n_scan = 0
    while (n_scan + 1) * nb <= times_s.size and times_s[(n_scan + 1) * nb - 1] + x_max / U <= t_end:
        n_scan += 1
    if n_scan < 2:
        raise ParameterError(
            f"store of {t_end:g} s is too short for the lidar: its farthest point (x = {x_max:g} m) "
            f"needs T + x/U <= {t_end:g} s"
        )
    T = times_s[: n_scan * nb].reshape(n_scan, nb)
    if not np.array_equal(beam_of_sample[: n_scan * nb].reshape(n_scan, nb), np.broadcast_to(order, (n_scan, nb))):
        raise ParameterError("lidar schedule: beams must be measured one at a time in a repeating order")
    col = {b: i for i, b in enumerate(order.tolist())}
    bi = {b: i for i, b in enumerate(beams)}
    gi = {gg: i for i, gg in enumerate(gates)}
    time_out = T[:, [col[b] for b in beams]]
    if mean_wind is not None and add_mean_wind:
        # veer and time-varying means rotate (u, v) per probe point: the profile's own path (MeanWind.full_uv)
        los = _los_with_mean_wind(fs, measurements, planes, T, col, mean_wind)
    else:
        op = los_operator(g, U, measurements, planes, np.stack([T[:, col[m.beam]] for m in measurements], axis=1))

        def read(c, ix, t, y, z):  # each plane read once, only the span its points need
            return np.asarray(fs.array(c)[t[0] : t[1], ix, y[0] : y[1], z[0] : z[1]], dtype=np.float64)

        los = apply_los(op, read)
        if add_mean_wind:
            los = los + mean_wind_los(measurements, U, fs.hub_height_m, shear_exponent)[None, :]
    v_los = np.zeros((n_scan, nb, ng))
    n1 = np.zeros((nb, ng))
    for j, m in enumerate(measurements):
        v_los[:, bi[m.beam], gi[m.gate]] = los[:, j]
        n1[bi[m.beam], gi[m.gate]] = m.n[0]
    gx = np.array([g.x_m[next(planes[j] for j, m in enumerate(measurements) if m.gate == gg)] for gg in gates], float)
    if mean_wind is not None and add_mean_wind:
        return LidarSamples(v_los.astype(np.float32), time_out, gx, n1, True, mean_wind.shear_exponent,
                            mean_wind.describe(), mean_wind.to_attrs())
    return LidarSamples(v_los.astype(np.float32), time_out, gx, n1, add_mean_wind, shear_exponent)


def _los_with_mean_wind(fs, measurements, planes, T, col, mean_wind):
    """v_los (n_scan, J) of fluctuations plus ``mean_wind`` at every probe point and stored time."""
    g, U = fs.grid, fs.U_m_s
    los = np.zeros((len(T), len(measurements)))
    y0, z0 = g.y()[0], g.z()[0]
    by_plane: dict[int, list[int]] = {}
    for j, ix in enumerate(planes):
        by_plane.setdefault(ix, []).append(j)
    for ix, idx in sorted(by_plane.items()):
        pts = [measurements[j].points_m() for j in idx]
        allp = np.concatenate(pts)
        iy, _ = interp_axis(y0, g.dy_m, g.ny, allp[:, 1])
        iz, _ = interp_axis(z0, g.dz_m, g.nz, allp[:, 2])
        y_lo, y_hi = int(iy.min()), min(int(iy.max()) + 2, g.ny)
        z_lo, z_hi = int(iz.min()), min(int(iz.max()) + 2, g.nz)
        t_lo = max(0, int(math.floor((T.min() + allp[:, 0].min() / U) / g.dt_s)))
        t_hi = min(g.nt, int(math.ceil((T.max() + allp[:, 0].max() / U) / g.dt_s)) + 2)
        # checked reads (a corrupted chunk, NaN or an implausible value is a one-line StoreError), whole yz planes
        # as the chunks hold them
        box = {c: np.asarray(fs.read_span(c, ix, t_lo, t_hi)[:, y_lo:y_hi, z_lo:z_hi], dtype=np.float64) for c in "uvw"}
        for j, p in zip(idx, pts):
            m = measurements[j]
            Tm = T[:, col[m.beam]]  # (n_scan,)
            t = Tm[:, None] + p[None, :, 0] / U  # (n_scan, k) stored time
            it, at = interp_axis(t_lo * g.dt_s, g.dt_s, t_hi - t_lo, t)
            jy, ay = interp_axis(y0 + y_lo * g.dy_m, g.dy_m, y_hi - y_lo, p[:, 1])
            jz, az = interp_axis(z0 + z_lo * g.dz_m, g.dz_m, z_hi - z_lo, p[:, 2])
            n = np.asarray(m.n, float)
            shape = box["u"].shape  # flat indices of the corners, shared by the three components
            corners = [((ti * shape[1] + yi) * shape[2] + zi, wc)
                       for ti, yi, zi, wc in _corners(it, at, jy, ay, jz, az, shape)]
            los[:, j] = weighted_sum(_with_mean_wind(mean_wind, fs, box, corners, n, t, p), m.weights)
    return los


def _with_mean_wind(mean_wind, fs, box, corners, n, t, p) -> np.ndarray:
    """Line-of-sight projection (n_scan, k) of fluctuations plus ``mean_wind`` at points ``p``, stored times ``t``."""
    h = _heights(fs.hub_height_m, p)
    vals = {c: sum(w * box[c].ravel()[idx] for idx, w in corners) for c in "uvw"}
    u, v = mean_wind.full_uv(vals["u"], vals["v"], t, p[None, :, 1], h[None, :], fs.U_m_s, fs.hub_height_m)
    return n[0] * u + n[1] * v + n[2] * vals["w"]


@dataclass(frozen=True, eq=False)
class LosOperator:
    """The virtual lidar as a sparse linear map of the fluctuations (no mean wind): v_los[s, j] = sum_r weight[s, j, r]
    n_j[c] field[c, plane[j], t_index, y_index, z_index], r over probe points x the 8 trilinear cell corners."""

    plane: np.ndarray  # (J,) plane index of each measurement
    n: np.ndarray  # (J, 3) projection vectors
    t_index: np.ndarray  # (n_scan, J, R)
    y_index: np.ndarray  # (J, R)
    z_index: np.ndarray  # (J, R)
    weight: np.ndarray  # (n_scan, J, R)


def los_operator(grid, U_m_s: float, measurements, planes, times_s: np.ndarray) -> LosOperator:
    """The operator of ``measurements`` at physical times ``times_s`` (n_scan, J) [s] (zero-weight corners clipped)."""
    g = grid
    y0, z0 = g.y()[0], g.z()[0]
    n_scan, n_meas = times_s.shape
    per = [m.points_m() for m in measurements]
    k_max = max(len(p) for p in per)
    t_index = np.zeros((n_scan, n_meas, 8 * k_max), np.int64)
    weight = np.zeros((n_scan, n_meas, 8 * k_max))
    y_index = np.zeros((n_meas, 8 * k_max), np.int64)
    z_index = np.zeros((n_meas, 8 * k_max), np.int64)
    for j, (m, p) in enumerate(zip(measurements, per)):
        k = len(p)
        t = times_s[:, j, None] + p[None, :, 0] / U_m_s  # (n_scan, k) stored time
        it, at = interp_axis(0.0, g.dt_s, g.nt, t)
        jy, ay = interp_axis(y0, g.dy_m, g.ny, p[:, 1])
        jz, az = interp_axis(z0, g.dz_m, g.nz, p[:, 2])
        w = np.asarray(m.weights, float)
        for r, (ti, yi, zi, wc) in enumerate(_corners(it, at, jy, ay, jz, az, (g.nt, g.ny, g.nz))):
            s = slice(r * k, (r + 1) * k)
            t_index[:, j, s], y_index[j, s], z_index[j, s], weight[:, j, s] = ti, yi, zi, wc * w
    return LosOperator(np.asarray(planes, np.int64), np.array([m.n for m in measurements], float), t_index,
                       y_index, z_index, weight)  # fmt: skip


def repeats_every(grid, U_m_s: float, measurements, times_s: np.ndarray, q: int, tol: float) -> bool:
    """Whether the probe points of ``measurements`` at times ``times_s`` (n_scan, J) [s] fall, scan after scan, q
    stored time steps later with the same weights (to ``tol``) as in the first scan: then :func:`los_operator` of the
    first scan, shifted by s q steps, is the operator of scan s."""
    g = grid
    for j, m in enumerate(measurements):
        p, w = m.points_m(), np.abs(np.asarray(m.weights, float))
        it, at = interp_axis(0.0, g.dt_s, g.nt, times_s[:, j, None] + p[None, :, 0] / U_m_s)
        end = at == 1.0  # the record's last node: the clipped lower cell with all weight on it, as it + 1 with none
        it, at = it + end, at - end
        _, ay = interp_axis(g.y()[0], g.dy_m, g.ny, p[:, 1])
        _, az = interp_axis(g.z()[0], g.dz_m, g.nz, p[:, 2])
        live = w > 0
        scale = w * np.maximum(ay, 1 - ay) * np.maximum(az, 1 - az)  # the largest weight a time fraction multiplies
        steps = it[:, live] - it[0, live][None, :]
        if not np.array_equal(steps, np.broadcast_to(q * np.arange(len(it))[:, None], steps.shape)):
            return False
        if (np.abs(at - at[0][None, :]) * scale[None, :]).max(initial=0.0) > tol:
            return False
    return True


def apply_los(op: LosOperator, read) -> np.ndarray:
    """v_los (n_scan, J) of the field given by ``read(component, plane, (t0, t1), (y0, y1), (z0, z1))`` -> the float64
    block [t0, t1) x [y0, y1) x [z0, z1) of that plane (each plane read once, only the span its points need)."""
    out = np.zeros(op.weight.shape[:2])
    for ix in np.unique(op.plane):
        js = np.flatnonzero(op.plane == ix)
        t = (int(op.t_index[:, js].min()), int(op.t_index[:, js].max()) + 1)
        y = (int(op.y_index[js].min()), int(op.y_index[js].max()) + 1)
        z = (int(op.z_index[js].min()), int(op.z_index[js].max()) + 1)
        for c, name in enumerate("uvw"):
            if not np.any(op.n[js, c]):
                continue
            block = read(name, int(ix), t, y, z)
            for j in js:
                if op.n[j, c] == 0.0:
                    continue
                vals = block[op.t_index[:, j] - t[0], op.y_index[j] - y[0], op.z_index[j] - z[0]]
                out[:, j] += op.n[j, c] * np.add.reduce(op.weight[:, j] * vals, axis=-1)
    return out


def mean_wind_los_series(measurements, times_s: np.ndarray, U_m_s: float, hub_height_m: float, mean_wind) -> np.ndarray:
    """The line-of-sight speed (n_scan, J) [m/s] of ``mean_wind`` alone: what :func:`sample` adds; ParameterError for a
    turning mean wind or a probe point below the ground."""
    if mean_wind.turns:
        raise ParameterError(f"lidar: the mean wind turns ({mean_wind.describe()}), which turns the fluctuations' "
                             "line of sight too; its line-of-sight part alone is not defined")
    out = np.zeros(np.shape(times_s))
    for j, m in enumerate(measurements):
        p = m.points_m()
        h = _heights(hub_height_m, p)
        t = times_s[:, j][:, None] + p[None, :, 0] / U_m_s
        u, _ = mean_wind.full_uv(0.0, 0.0, t, p[None, :, 1], h[None, :], U_m_s, hub_height_m)
        out[:, j] = m.n[0] * weighted_sum(u, m.weights)
    return out


def mean_wind_los(measurements, U_m_s: float, hub_height_m: float, shear_exponent: float) -> np.ndarray:
    """The line-of-sight speed (J,) [m/s] of the power-law mean wind U (h / h_hub)^alpha alone, per measurement
    (what ``add_mean_wind`` adds to v_los). Raises ParameterError for a probe point below the ground."""
    out = np.zeros(len(measurements))
    for j, m in enumerate(measurements):
        h = _heights(hub_height_m, m.points_m())
        out[j] = m.n[0] * weighted_sum(U_m_s * (h / hub_height_m) ** shear_exponent, m.weights)
    return out
