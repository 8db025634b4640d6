"""The lidar output dataset: a small zarr group, xarray-readable, written atomically.

v_los (scan, beam, gate) [m s-1] positive towards the lidar, time_s (scan, beam) [s], u_LL and u_RR
(t_arrival), gate_x_m, n1; attributes: the lidar, the source store, the mean wind added, the TIs."""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError, StoreError
from turbgen.store.attributes import jsonable
from turbgen.store.temporaries import publish, temp_name
from turbgen.theory import ranges

MARKER = "turbgen_lidar_complete"


def check_output(path, overwrite: bool) -> Path:
    """The absolute output path, checked before any work: StoreError if it exists without ``overwrite`` or is not a
    lidar dataset, or its directory is missing or read-only."""
    path = Path(path).expanduser().absolute()
    # a path that is not a lidar dataset is never replaced, so `overwrite` is no remedy there: not suggested
    if path.exists() and not (path / "zarr.json").is_file():
        raise StoreError(f"{path} exists and is not a zarr dataset; it will not be replaced (choose another `out`)")
    if path.exists() and not (path / "v_los" / "zarr.json").is_file():  # e.g. the field store being measured
        raise StoreError(f"{path} exists and is not a lidar dataset (no v_los); it will not be replaced "
                         "(choose another `out`)")
    if path.exists() and not overwrite:
        raise StoreError(f"{path} already exists; use `overwrite` to replace it")
    if not path.parent.is_dir():
        raise StoreError(f"output directory {path.parent} does not exist")
    if not os.access(path.parent, os.W_OK):
        raise StoreError(f"output directory {path.parent} is not writable")
    return path


def write_dataset(path, samples, t_arrival, u_ll, u_rr, attrs: dict, overwrite: bool = False) -> Path:
    """Write the lidar dataset atomically at ``path`` (marker last, then publish); return its absolute path; ``attrs``:
    dict, list and tuple values are stored as JSON. StoreError as :func:`check_output`."""
    import xarray as xr

    path = check_output(path, overwrite)
    nb, ng = samples.v_los.shape[1:]
    ds = xr.Dataset(
        {
            "v_los": (("scan", "beam", "gate"), samples.v_los.astype(np.float32),
                      {"units": "m s-1", "long_name": "line-of-sight speed, positive towards the lidar"}),
            "u_LL": (("t_arrival",), u_ll.astype(np.float32),
                     {"units": "m s-1", "long_name": "lidar estimate of the rotor-effective wind speed (moving full-scan window)"}),
            "u_RR": (("t_arrival",), u_rr.astype(np.float32),
                     {"units": "m s-1", "long_name": "u averaged over the rotor disc at x = 0"}),
            "n1": (("beam", "gate"), samples.n1, {"units": "1", "long_name": "longitudinal component of the beam vector"}),
        },
        coords={
            "time_s": (("scan", "beam"), samples.time_s, {"units": "s", "long_name": "physical time of the measurement"}),
            "t_arrival": (("t_arrival",), t_arrival, {"units": "s", "long_name": "rotor arrival time (eddy time of plane x = 0)"}),
            "gate_x_m": (("gate",), samples.gates_x_m, {"units": "m", "long_name": "upstream distance of the range gate"}),
            "beam": (("beam",), np.arange(nb)),
            "gate": (("gate",), np.arange(ng)),
        },
        attrs={k: json.dumps(jsonable(v)) if isinstance(v, (dict, list, tuple)) else jsonable(v) for k, v in attrs.items()},
    )
    tmp = temp_name(path)
    try:
        import zarr

        from turbgen.store.layout import silence_consolidated_metadata_warning

        silence_consolidated_metadata_warning()

        ds.attrs[MARKER] = False
        ds.to_zarr(tmp, mode="w", consolidated=True)
        zarr.open_group(str(tmp), mode="r+").attrs[MARKER] = True  # the completeness marker, last
        zarr.consolidate_metadata(str(tmp))
        old = publish(tmp, path, replace=True)  # an older dataset is swapped out in one step, then removed
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return path


@dataclass(frozen=True, eq=False)
class LidarData:
    """What ``turbgen lidar --out`` wrote, as needed to constrain a field with it."""

    v_los: np.ndarray  # (scan, beam, gate) [m/s] (NaN missing)
    time_s: np.ndarray  # (scan, beam) [s]
    lidar: dict  # the description's fields
    mean_wind_added: bool
    shear_exponent: float
    U_m_s: float  # the store's mean wind [m/s]
    source: str
    mean_wind: dict | None = None  # its ``MeanWind.to_attrs`` (None: the power law)

    def __post_init__(self):
        # NaN is a missing sample; inf or 1e30 m/s is no measurement (the field would follow it)
        ranges.check_values("measured_m_s", self.v_los, f"lidar record {self.source}: v_los")


def is_lidar_dataset(path) -> bool:
    """Whether ``path`` is a directory holding a lidar dataset (a ``v_los`` array)."""
    return (Path(path) / "v_los" / "zarr.json").is_file()


def read_dataset(path) -> LidarData:
    """Read a complete lidar dataset written by :func:`write_dataset` (StoreError otherwise)."""
    import zarr

    p = Path(path)
    try:
        group = zarr.open_group(str(p), mode="r")
        attrs = dict(group.attrs)
        if attrs.get(MARKER) is not True:
            raise StoreError(f"{p} is not a complete lidar dataset (no completeness marker)")
        lidar, wind = attrs["lidar"], attrs.get("mean_wind")
        return LidarData(np.asarray(group["v_los"][...], float), np.asarray(group["time_s"][...], float),
                         json.loads(lidar) if isinstance(lidar, str) else dict(lidar),
                         bool(attrs["mean_wind_added"]), float(attrs["shear_exponent"]), float(attrs["U_m_s"]),
                         str(p), json.loads(wind) if isinstance(wind, str) else wind)  # fmt: skip
    except ParameterError:  # it reads, but a value is no measurement (LidarData)
        raise
    except (KeyError, ValueError, OSError, RuntimeError, zarr.errors.BaseZarrError) as exc:  # RuntimeError: a chunk
        first = (str(exc).splitlines() or [""])[0]  # that does not decompress (numcodecs' Zstd error)
        raise StoreError(f"{p} is not a readable lidar dataset ({type(exc).__name__}: {first})") from None
