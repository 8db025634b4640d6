"""The series a fit reads: fluctuations of u, v, w at one or more points, from a point-series file or a store.

A store is read at a sub-lattice of at most STORE_POINTS_PER_AXIS^2 points per plane (unbiased Welch averages; the
fit's variances are those of the same points), its periodic records as they are; a sensor's series is detrended
(its least-squares line through the finite values removed), a trend larger than its standard deviation said in the
notes (the record may not be stationary). Missing values (NaN): the Welch estimates skip the segments holding them.
A sensor's total-wind u and v are first turned into its own mean wind direction (``along_wind``): the model's u is
along the mean wind, and a sonic's axes seldom are. For the Mann fits the sensors' positions are turned into the
wind's frame too (``in_wind_frame``): two masts are apart along the wind and across it."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.stats import circmean

from turbgen.errors import ParameterError
from turbgen.spec.constraints import COMPONENTS, PointSeries, load_point_series
from turbgen.spec.point_csv import is_point_csv
from turbgen.theory import ranges
from turbgen.theory.mean_wind import rotate_horizontal
from turbgen.validation.fit.mean_wind import mean_direction_deg
from turbgen.validation.point_sets import long_sublattice
from turbgen.validation.store_run import MannBox, mann_box_from_attrs

STORE_POINTS_PER_AXIS = 8  # points per axis and plane read from a store (the spectra are averaged over them)
TURN_NOTE_DEG = 1.0  # the notes name the turn into the mean wind when a sensor's exceeds this [deg]
UNIFORM_RTOL = 1e-6  # sample times are uniform when every step is within this of the mean step


@dataclass(frozen=True, eq=False)
class FitData:
    """Fluctuation series to fit to (``box``, ``grid``, ``attrs`` are None for sensor data, ``points`` for a field)."""

    source: str  # the file or store read (for messages and the result)
    dt_s: float  # sampling interval [s]
    U_m_s: float  # mean wind speed [m/s] of Taylor's hypothesis k1 = 2 pi f / U
    series: dict  # component ("u", "v", "w") -> (nt, P) fluctuations [m/s] of the P points holding it (NaN: missing)
    uw_columns: tuple  # (column of u, column of w) pairs of the points holding both (the u-w cross-spectrum)
    box: MannBox | None = None  # a turbgen Mann store's periodic box (fit to the grid's discrete expectation)
    grid: object = None  # the store's turbgen.grid.Grid (with ``box``)
    notes: tuple = ()  # what was done to the data (trends removed, missing values)
    points: PointSeries | None = None  # the sensor data as read (their mean wind: turbgen.validation.fit.mean_wind)
    sites_m: np.ndarray | None = None  # (N, 3) positions x, y, z [m] of the points (z a height if a sensor gives one)
    columns: dict | None = None  # component -> (P,) index into ``sites_m`` of each column of ``series``
    u_xyz_m: tuple = ()  # (x [m upstream], y [m], z [m]) of every column of u (``fit.evolution``)
    attrs: dict | None = None  # a field's store attributes (its model and parameters)
    path_m: np.ndarray | None = None  # (N,) sonic path length [m] of every point (0: a point); None: all are points
    turned_deg: float | None = None  # turn [deg] of ``sites_m``, ``u_xyz_m`` into the wind's frame (``in_wind_frame``)

    @property
    def nt(self) -> int:
        return next(iter(self.series.values())).shape[0]

    def spectrum_paths(self) -> dict:
        """Spectrum ("uu", "vv", "ww", "uw") -> (P,) path lengths [m] of the columns averaged into it ({}: points)."""
        if self.path_m is None:
            return {}
        uw = {"uw": self.path_m[self.columns["u"][[a for a, _ in self.uw_columns]]]} if self.uw_columns else {}
        return {c + c: self.path_m[self.columns[c]] for c in self.series} | uw


def detrended(x: np.ndarray, where) -> tuple[np.ndarray, list]:
    """The columns of ``x`` (nt, P) [m/s] minus their least-squares lines through their finite values, and a note for
    every column whose line rises over the record by more than the sd about it (``where(k)`` names column k)."""
    ok = np.isfinite(x)
    w = ok.astype(float)
    t = np.arange(x.shape[0], dtype=float)[:, None]
    xz = np.where(ok, x, 0.0)
    n, st, sx = w.sum(0), (w * t).sum(0), xz.sum(0)
    with np.errstate(invalid="ignore", divide="ignore"):  # a column without 2 values stays NaN (refused later)
        slope = (n * (t * xz).sum(0) - st * sx) / (n * (w * t * t).sum(0) - st**2)
        out = x - (slope * t + (sx - slope * st) / n)
    rise = np.abs(slope) * (x.shape[0] - 1)
    sigma = np.sqrt(np.nansum(out**2, axis=0) / np.maximum(np.isfinite(out).sum(0), 1))
    notes = [f"{where(k)}: a trend of {rise[k]:.3g} m/s over the record, more than its standard deviation "
             f"{sigma[k]:.3g} m/s, was removed (the record may not be stationary)"
             for k in np.flatnonzero(rise > sigma)]
    return out, notes


def data_from_points(ps: PointSeries, U_m_s: float | None = None) -> FitData:
    """FitData of a point-series file ``ps`` (uniform sample times): every sensor's u, v, w, detrended (module
    docstring); ``U_m_s`` [m/s] defaults to the mean of u of total-wind data. ParameterError for non-uniform sample
    times, or no U for fluctuation data."""
    where = f"point-series file {ps.source}"
    steps = np.diff(ps.time_s)
    dt = float(steps.mean())
    if np.any(np.abs(steps - dt) > UNIFORM_RTOL * dt):
        raise ParameterError(f"{where}: time_s is not uniformly sampled (steps {steps.min():g} to {steps.max():g} s); "
                             "the Welch spectra need one sampling interval")
    aligned, notes = along_wind(ps)
    if U_m_s is None:
        u_means = [np.nanmean(a["u"]) for a in aligned if "u" in a]
        if not ps.total_wind or not u_means:
            raise ParameterError(f"{where}: the data are fluctuations: give the mean wind speed U (--U) for "
                                 "k1 = 2 pi f / U")
        U_m_s = float(np.mean(u_means))
    U = ranges.check("U_m_s", U_m_s, "U (mean wind speed, m/s)")
    series = {}
    for c in COMPONENTS:
        names = [s.name for s in ps.sensors if c in s.series]
        if names:
            cols = np.stack([a[c] for a in aligned if c in a], axis=1)
            series[c], more = detrended(cols, lambda k, c=c, names=names: f"{names[k]} {c}")
            notes += more
    with_u = [s for s in ps.sensors if "u" in s.series]
    with_w = [s for s in ps.sensors if "w" in s.series]
    uw = tuple((with_u.index(s), with_w.index(s)) for s in ps.sensors if s in with_u and s in with_w)
    gaps = [f"{s.name} {c}: {int(np.isnan(v).sum())} missing values (Welch segments holding them are skipped)"
            for s, a in zip(ps.sensors, aligned) for c, v in a.items() if np.isnan(v).any()]
    sites = np.array([(s.x_m, s.y_m, s.z_m if s.z_m is not None else s.height_m) for s in ps.sensors], float)
    columns = {c: np.array([k for k, s in enumerate(ps.sensors) if c in s.series]) for c in series}
    paths = np.array([s.path_m or 0.0 for s in ps.sensors])
    return FitData(ps.source, dt, U, series, uw, notes=tuple(notes + gaps), points=ps, sites_m=sites, columns=columns,
                   u_xyz_m=tuple(map(tuple, sites[columns["u"]])) if "u" in columns else (),
                   path_m=paths if paths.any() else None)


def along_wind(ps: PointSeries) -> tuple[list[dict], list[str]]:
    """Every sensor's series, a total-wind sensor's u and v turned into its mean wind direction atan2(v̄, ū) (the yaw
    rotation of sonic data, Wilczak et al. 2001; a sample missing either is missing in both), and a note naming the
    largest turn beyond TURN_NOTE_DEG."""
    out, turns = [], {}
    for s in ps.sensors:
        u, v = s.series.get("u"), s.series.get("v")
        if not (ps.total_wind and u is not None and v is not None):
            out.append(s.series)
            continue
        turns[s.name] = mean_direction_deg(u, v)
        along, across = rotate_horizontal(u, v, -turns[s.name])
        out.append({**s.series, "u": along, "v": across})
    big = max(turns, key=lambda k: abs(turns[k]), default=None)
    if big is None or abs(turns[big]) <= TURN_NOTE_DEG:
        return out, []
    return out, [f"the mean wind blows up to {turns[big]:+.1f} deg from x ({big}; counter-clockwise seen from above): "
                 "u and v were turned into each sensor's mean wind direction, along which the model's u lies (and "
                 "for the Mann fit the sensors' x and y into their mean direction)"]


def in_wind_frame(data: FitData) -> FitData:
    """``data`` with the sensors' (x, y) (``sites_m``, ``u_xyz_m``) turned about the origin by minus the mean of the
    total-wind sensors' directions (their circular mean, the direction of their mean unit vector): x along the
    mean wind, as the model's (the Mann fits: the covariance of the sensors' spectra and the longitudinal coherence
    depend on their separations along and across the wind). ``data`` itself for a field, fluctuation data, sensors
    without u and v, or data already turned."""
    ps = data.points
    with_uv = [s for s in ps.sensors if {"u", "v"} <= s.series.keys()] if ps is not None and ps.total_wind else []
    if not with_uv or data.sites_m is None or data.turned_deg is not None:
        return data
    mean_deg = float(circmean([mean_direction_deg(s.series["u"], s.series["v"]) for s in with_uv], high=180.0,
                              low=-180.0))
    x, y = rotate_horizontal(data.sites_m[:, 0], data.sites_m[:, 1], -mean_deg)
    sites = np.column_stack([x, y, data.sites_m[:, 2]])
    u_xyz = tuple(map(tuple, sites[data.columns["u"]])) if data.columns and "u" in data.columns else ()
    return replace(data, sites_m=sites, u_xyz_m=u_xyz, turned_deg=mean_deg)


def data_from_store(fs, points=None) -> FitData:
    """FitData of a FieldStore ``fs`` (a Mann store also gives its periodic box for the grid's expectation): u, v, w
    at a sub-lattice of every plane, or at the (y, z) [m] ``points`` (``grid_points``): sensors cut from the field."""
    return _grid_data(lambda c, ix: fs.read_span(c, ix, 0, fs.grid.nt), fs.grid, fs.attrs, str(fs.path), points)


def data_from_dataset(ds, points=None) -> FitData:
    """FitData of a field as an xarray.Dataset of ``turbgen.mann`` / ``turbgen.kaimal`` / ``turbgen.open_store``
    (in memory or not; its attributes are the store's); ``points`` as in ``data_from_store``."""
    from turbgen.grid import Grid

    g = dict(ds.attrs["grid"])
    grid = Grid(**{**g, "x_m": tuple(g["x_m"])})
    return _grid_data(lambda c, ix: ds[c].isel(x=ix).values, grid, ds.attrs,
                      ds.encoding.get("source", "the field in memory"), points)


def grid_points(grid, points) -> tuple[np.ndarray, np.ndarray]:
    """(iy, iz) grid indices of the (y, z) [m] ``points`` (each within half a step of a grid point), or of the
    sub-lattice of STORE_POINTS_PER_AXIS^2 points when ``points`` is None.

    Raises
    ------
    ParameterError
        For a point farther than half a grid step from every grid point, or a repeated point.
    """
    if points is None:
        iy, iz = long_sublattice(grid.ny, STORE_POINTS_PER_AXIS), long_sublattice(grid.nz, STORE_POINTS_PER_AXIS)
        return np.repeat(iy, iz.size), np.tile(iz, iy.size)
    yz = np.asarray(points, dtype=float).reshape(-1, 2)
    iy = np.rint(yz[:, 0] / grid.dy_m + (grid.ny - 1) / 2).astype(int)
    iz = np.rint(yz[:, 1] / grid.dz_m + (grid.nz - 1) / 2).astype(int)
    far = (iy < 0) | (iy >= grid.ny) | (iz < 0) | (iz >= grid.nz)
    off = np.maximum(np.abs(yz[:, 0] - grid.y()[np.clip(iy, 0, grid.ny - 1)]) / grid.dy_m,
                     np.abs(yz[:, 1] - grid.z()[np.clip(iz, 0, grid.nz - 1)]) / grid.dz_m)
    bad = np.flatnonzero(far | (off > 0.5 + 1e-9))
    if bad.size:
        y, z = yz[bad[0]]
        raise ParameterError(f"point (y, z) = ({y:g}, {z:g}) m is not on the grid: y in [{grid.y()[0]:g}, "
                             f"{grid.y()[-1]:g}] m step {grid.dy_m:g}, z in [{grid.z()[0]:g}, {grid.z()[-1]:g}] m "
                             f"step {grid.dz_m:g}")
    if len(set(zip(iy, iz))) < iy.size:
        raise ParameterError(f"points = {yz.tolist()}: two of them are the same grid point")
    return iy, iz


def _grid_data(read, g, attrs: dict, source: str, points=None) -> FitData:
    """FitData of a field on grid ``g``: ``read(component, ix)`` -> (nt, ny, nz) of plane ix; the box from ``attrs``."""
    iy, iz = grid_points(g, points)
    series = {c: np.concatenate([np.asarray(read(c, ix))[:, iy, iz] for ix in range(g.nx)], axis=1).astype(float)
              for c in COMPONENTS}  # fmt: skip
    sites = np.array([(x, y, z) for x in g.x_m for y, z in zip(g.y()[iy], g.z()[iz])])
    n = sites.shape[0]
    box = mann_box_from_attrs(attrs, g) if attrs.get("model") == "mann" else MannBox(g.ny, g.nz)
    if points is not None:
        source += f" at {iy.size} point(s) (y, z) = " + ", ".join(f"({y:g}, {z:g})" for y, z in
                                                                  zip(g.y()[iy], g.z()[iz]))
    return FitData(source, g.dt_s, float(attrs["U_m_s"]), series, tuple((k, k) for k in range(n)), box, g,
                   sites_m=sites, columns={c: np.arange(n) for c in COMPONENTS}, u_xyz_m=tuple(map(tuple, sites)),
                   attrs=dict(attrs))


def load_fit_data(data, U_m_s: float | None = None, points=None) -> FitData:
    """FitData of ``data``: a PointSeries, a FieldStore, an xarray.Dataset of a field, or the path of a point-series
    JSON file or of a store; ``points`` (y, z) [m] restrict a field to those grid points (``grid_points``).
    ParameterError for an unreadable or invalid file, a path neither a JSON file nor a directory, ``U_m_s`` for a
    field (it holds its own), ``points`` for point series or off the grid; StoreError for an incomplete store."""
    from turbgen.store import FieldStore, open_store

    if points is not None and (isinstance(data, PointSeries) or (isinstance(data, (str, Path))
                                                              and not Path(data).expanduser().is_dir())):
        raise ParameterError("points select grid points of a field; a point-series file is fitted at its sensors")
    if isinstance(data, PointSeries):
        return data_from_points(data, U_m_s)
    if isinstance(data, (str, Path)):
        p = Path(data).expanduser()
        if not p.is_dir():
            if p.exists() and not (p.suffix.lower() == ".json" or is_point_csv(p)):
                raise ParameterError(f"DATA = {str(data)!r} is neither a point-series JSON or CSV file nor a store "
                                     "directory")
            return data_from_points(load_point_series(p), U_m_s)
        data = open_store(p)
    if U_m_s is not None:
        raise ParameterError(f"U = {U_m_s!r}: a field holds its own mean wind speed; drop --U / U")
    return data_from_store(data, points) if isinstance(data, FieldStore) else data_from_dataset(data, points)
