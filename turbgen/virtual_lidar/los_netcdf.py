"""Measured line-of-sight data as a netCDF file, for ``turbgen mann --constrain FILE.nc``.

The CSV table (:mod:`turbgen.virtual_lidar.los_csv`) as four 1-D variables, its header keys as global attributes.
netCDF4/HDF5 files need ``turbgen[netcdf]``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.virtual_lidar.dataset import LidarData
from turbgen.input_files import LINE_OF_SIGHT, check_input
from turbgen.virtual_lidar.los_csv import COLUMNS, HEADER_KEYS, los_record

SUFFIXES = (".nc", ".nc4", ".netcdf")


def is_los_netcdf(path) -> bool:
    """Whether ``path`` names a netCDF file (by its suffix)."""
    return Path(path).suffix.lower() in SUFFIXES


def _header(attrs: dict, where: str) -> dict:
    unknown = sorted(set(attrs) - set(HEADER_KEYS))
    if unknown:
        raise ParameterError(f"{where}: unknown global attribute {unknown[0]!r} (allowed: {', '.join(HEADER_KEYS)})")
    header = {}
    for key, value in attrs.items():
        value = value.item() if isinstance(value, np.generic) else value
        if key == "total_wind" and not isinstance(value, str):
            value = {1: "true", 0: "false"}.get(value, str(value))
        header[key] = str(value)
    return header


def read_los_netcdf(path) -> LidarData:
    """The line-of-sight record of a netCDF file as :class:`LidarData`; ParameterError if unreadable (or no engine
    installed), a variable or attribute is missing, unknown or malformed, or a check of ``los_csv.read_los_csv``
    fails."""
    import xarray as xr

    path = Path(path).expanduser()
    where = f"line-of-sight file {path}"
    check_input(path, LINE_OF_SIGHT)
    try:
        with xr.open_dataset(path, decode_times=False) as ds:
            ds.load()
    except (OSError, ValueError) as exc:  # not netCDF, or no engine installed for its format
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ParameterError(f"{where}: not readable as netCDF ({reason}); netCDF4 files need "
                             '`pip install "turbgen[netcdf]"`') from None  # fmt: skip
    missing = [name for name in COLUMNS if name not in ds.variables]
    if missing:
        raise ParameterError(f"{where}: the variables must be {', '.join(COLUMNS)} (missing {', '.join(missing)})")
    columns = [ds[name] for name in COLUMNS]
    if any(c.ndim != 1 or c.dims != columns[0].dims for c in columns):
        raise ParameterError(f"{where}: {', '.join(COLUMNS)} must be 1-D along the same dimension")
    try:
        table = np.column_stack([np.asarray(c.values, dtype=float) for c in columns])
    except (TypeError, ValueError):
        raise ParameterError(f"{where}: {', '.join(COLUMNS)} must hold numbers") from None
    if len(table) == 0:
        raise ParameterError(f"{where}: no samples")
    return los_record(path, _header(dict(ds.attrs), where), table, where)
