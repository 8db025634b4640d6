"""``turbgen.fit_mann``, ``turbgen.fit_kaimal``: models fitted to measured or generated data (``turbgen fit ...``)."""

from __future__ import annotations

import math
import os
from dataclasses import replace

import numpy as np

from turbgen.errors import ParameterError
from turbgen.exporters.field_files import FORMATS as WIND_FILES
from turbgen.exporters.field_files import open_wind_file
from turbgen.runs.constrain import load_constraint
from turbgen.spec.point_csv import is_point_csv
from turbgen.validation.fit import MannFit, fit_mann_data, load_fit_data
from turbgen.validation.fit.evolution import with_evolution
from turbgen.validation.fit.kaimal import fit_kaimal_data
from turbgen.validation.fit.kaimal_result import KaimalFit
from turbgen.validation.fit.mean_wind import fit_mean_wind
from turbgen.virtual_lidar.dataset import LidarData, is_lidar_dataset
from turbgen.virtual_lidar.fit import fit_lidar
from turbgen.virtual_lidar.los_csv import is_los_csv
from turbgen.virtual_lidar.los_netcdf import is_los_netcdf
from turbgen.virtual_lidar.report import LidarReport


def fit_mann(data, *, U: float | None = None, nperseg: int | None = None, points=None,
             bootstrap: int = 0, gamma: float | None = None, lifetime: str | None = None) -> MannFit:
    """Fit ae, L, Gamma (Mann 1994) to the spectra of ``data`` and the evolution time gamma to its x coherence.

    The one-point spectra of u, v, w and the u-w co-spectrum are estimated (Welch, detrended), each band weighted by
    the estimator's own covariance; a turbgen store is fitted against the Mann tensor summed over its generator's box
    (what the grid can hold), sensor data against the continuous model (Mann 1994, Eq. 13-17; Guo et al. 2023,
    Eq. 8). Total-wind sensor data also give their mean wind: power-law exponent, roughness length, veer and
    turbulence intensity (``mean_wind``; turbgen.validation.fit.mean_wind).

    Parameters
    ----------
    data : str, os.PathLike, PointSeries, LidarReport, LidarData, FieldStore or xarray.Dataset
        A point-series JSON or CSV file (the ``--constrain`` formats: one or more sensors with any of u, v, w) or
        the same made in memory (:func:`turbgen.point_series`), a field store, a field as a Dataset (``turbgen.mann``,
        in memory or not, ``turbgen.open_store``), a TurbSim ``.bts`` or a HAWC2 ``.htc`` whose ``begin mann`` block
        names the boxes (fitted against the Mann tensor summed over their periodic box,
        ``turbgen.exporters.field_files``), or a lidar record: a ``turbgen lidar --out`` dataset, a line-of-sight
        CSV or netCDF file (the ``--constrain`` formats) or what ``turbgen.lidar`` returned (ae and L from its
        line-of-sight spectra with the probe volume, Gamma held, the evolution time from gates along x:
        ``turbgen.virtual_lidar.fit``).
    U : float, optional
        Mean wind speed [m/s] of k1 = 2 pi f / U for fluctuation data (default: the mean of u of total-wind data;
        a store holds its own).
    nperseg : int, optional
        Welch segment length [samples] (default: the largest power of two <= nt / 8, at most 4096).
    points : sequence of (y, z) [m], optional
        For a field: fit only the series at these grid points of every plane (sensors cut from the field, fitted
        against the grid's expectation there); default a sub-lattice of 8 x 8 points per plane.
    bootstrap : int, optional
        B >= 2: check the intervals by a parametric bootstrap (``bootstrap_sd``), reported in ``fit.bootstrap``;
        0 (default): none. Fields only.
    gamma : float, optional
        For a lidar record: the Gamma [-] held (default 3.1, the generator's); other data fit it.
    lifetime : {"guo", "mann"}, optional
        The model's eddy lifetime: Guo et al. (2023, Eq. 6-7; the generator's default) or Mann (1994), as HAWC2's
        and wetb's. Default: a turbgen store's own (a contradicting value is refused), else "guo".

    Returns
    -------
    turbgen.validation.fit.MannFit
        ``ae``, ``length_scale_m``, ``gamma`` (each ``value`` and ``ci95``), ``chi2_dof``, ``flags`` (no
        convergence, a range boundary: ``ok`` is False), ``notes``, ``mean_wind``, ``to_dict()``, ``table()``,
        ``plot(path)``; ``evolution``: the eddy-evolution time from the co-coherence of u at points along x (two
        masts, two planes), None without such points (Guo et al. 2023, Eq. 13, 16).

    Raises
    ------
    ParameterError
        For bad input: an unreadable file, a non-uniform or non-stationary record, too few Welch segments, a
        bootstrap of point series or with B < 2, a ``lifetime`` other than the store's.
    StoreError
        For a directory that is not a complete turbgen store.

    Examples
    --------
    >>> import turbgen
    >>> fit = turbgen.fit_mann("examples/mast-fit.json")  # doctest: +SKIP
    >>> fit.length_scale_m.value, fit.length_scale_m.ci95  # doctest: +SKIP
    """
    data = _opened(data)
    if isinstance(data, LidarData):
        if U is not None or points is not None or bootstrap or lifetime not in (None, "guo"):
            raise ParameterError(f"DATA = {data.source!r} is a lidar record: it holds its own U and gates; U, points, "
                                 "bootstrap and a lifetime other than 'guo' do not apply")
        return fit_lidar(data, nperseg, gamma)
    if gamma is not None:
        raise ParameterError(f"gamma = {gamma!r}: a held Gamma applies to a lidar record only (other data fit it)")
    if bootstrap and (isinstance(bootstrap, bool) or not isinstance(bootstrap, int) or bootstrap < 2):
        raise ParameterError(f"bootstrap = {bootstrap!r} must be an integer >= 2 (realisations), or 0 for none")
    fd = load_fit_data(data, U, points)
    if bootstrap and fd.grid is None:
        raise ParameterError(f"bootstrap = {bootstrap}: the parametric bootstrap regenerates the data's grid; "
                             f"{fd.source} holds point series, not a field")
    fit = with_evolution(fd, replace(fit_mann_data(fd, nperseg, lifetime=lifetime), mean_wind=fit_mean_wind(fd.points)))
    return replace(fit, bootstrap=bootstrap_sd(fit, fd, bootstrap, points)) if bootstrap else fit


def bootstrap_sd(fit: MannFit, data, B: int, points=None) -> dict:
    """{"B": B, "sd": {name: sd}, "sd_fit": {name: the fit's analytic sd}}: sd of the fitted ln ae, ln L and Gamma
    over B frozen fields (seeds 1 .. B) made at the fitted parameters on the fitted field's grid and box, each fitted
    like it. With calibrated intervals sd / sd_fit is sqrt(chi2_(B-1) / (B-1)) distributed (Gaussian estimates)."""
    from turbgen.api.fields import mann

    g, p, names = data.grid, fit.params, ("ae", "length_scale_m", "gamma")
    xs = []
    for seed in range(1, B + 1):
        ds = mann(L=p.length_scale_m, gamma=p.gamma, ae=p.ae, evo=None, seed=seed, U=data.U_m_s,
                  lifetime=p.lifetime, planes=list(g.x_m), nt=g.nt, dt=g.dt_s, ny=g.ny, nz=g.nz, dy=g.dy_m, dz=g.dz_m,
                  pad_yz=data.box.nyp // g.ny)
        f = fit_mann_data(load_fit_data(ds, None, points), fit.nperseg)
        xs.append([math.log(f.ae.value), math.log(f.length_scale_m.value), f.gamma.value])
    sd = np.std(np.array(xs), axis=0, ddof=1)
    return {"B": B, "sd": dict(zip(names, map(float, sd))), "sd_fit": {n: getattr(fit, n).sd_fit for n in names}}


def _opened(data):
    """``data`` with a path as a str, a .bts or HAWC2 .htc opened as a field (turbgen.exporters.field_files), and a
    lidar record (a LidarReport, a lidar dataset, a line-of-sight CSV or netCDF file) as the LidarData
    ``--constrain`` reads."""
    if isinstance(data, LidarReport):
        return data.data()
    if isinstance(data, os.PathLike):
        data = os.fspath(data)
    if isinstance(data, str) and os.path.splitext(data)[1].lower() in WIND_FILES:
        return open_wind_file(data)
    if isinstance(data, str) and (is_lidar_dataset(data) or is_los_netcdf(data)
                                  or (is_los_csv(data) and not is_point_csv(data))):
        return load_constraint(data)
    return data


def fit_kaimal(data, *, U: float | None = None, nperseg: int | None = None, points=None) -> KaimalFit:
    """Fit the IEC Kaimal model to ``data``: sigma_k [m/s], L_k [m] of the u, v, w spectra, a [-] and Lc [m] of the
    u coherence exp(-a r sqrt((f/U)^2 + (0.12/Lc)^2)) (IEC 61400-1 Annex C; Guo et al. 2023, Eq. 11-12).

    The Welch spectra of u, v, w are fitted by generalised least squares with each band's weight from the
    estimator's covariance; a and Lc to the u co-coherence between sensors at one x, apart in y or z (not identified
    with one sensor). 95 % intervals from the fits' covariances (turbgen.validation.fit.kaimal).

    Parameters
    ----------
    data, U, nperseg, points
        As :func:`fit_mann` (a store with several planes: its first plane).

    Returns
    -------
    turbgen.validation.fit.kaimal_result.KaimalFit
        ``values`` (name -> ``value``, ``ci95``; a name missing is not identified), ``chi2_dof``, ``flags`` (``ok``
        False), ``notes``, ``to_dict()``, ``table()``, ``plot(path)``.

    Raises
    ------
    ParameterError, StoreError
        As :func:`fit_mann`.

    Examples
    --------
    >>> import turbgen
    >>> ds = turbgen.kaimal(U=10, nt=2048, ny=4, nz=4, dy=12, dz=12, planes=[0], seed=1)  # doctest: +SKIP
    >>> fit = turbgen.fit_kaimal(ds, points=[(-6, z) for z in (-18, -6, 6, 18)])  # doctest: +SKIP
    >>> fit.values["length_u_m"].ci95, fit.values["a_yz"].value  # doctest: +SKIP
    """
    data = _opened(data)
    if isinstance(data, LidarData):
        raise ParameterError(f"DATA = {data.source!r} is a lidar record: the Kaimal fit takes point series and "
                             "fields; fit a lidar record with turbgen fit mann")
    return fit_kaimal_data(load_fit_data(data, U, points), nperseg)
