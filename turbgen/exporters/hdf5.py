"""HDF5 copy of the whole 4D field (h5py): u, v, w, the coordinates t, x, y, z and the store's attributes.

Velocities have C shape (nz, ny, nx, nt), so MATLAB's ``h5read(f, '/u')`` returns the store's (t, x, y, z);
stored float32 fluctuations in the convected frame."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from turbgen.exporters.outputs import OutputSet
from turbgen.exporters.request import COMPONENTS, ExportRequest, ExportResult

_COORDS = {"t": ("s", "eddy (convected-frame) time"), "x": ("m", "upstream distance from the rotor"),
           "y": ("m", "lateral, +y left looking downwind"), "z": ("m", "vertical relative to hub height, up")}
_CHUNK_BYTES = 1 << 22
DIMENSION_ORDER = "MATLAB h5read: (t, x, y, z); row-major (h5py/NumPy): (z, y, x, t)"


def _attr_value(value):
    """HDF5-storable attribute: numbers, strings and bools as they are, anything else as JSON."""
    return value if isinstance(value, (bool, int, float, str, np.number)) else json.dumps(value)


def export_hdf5(fs, out, req: ExportRequest) -> ExportResult:
    """Export the whole store ``fs`` to the HDF5 file ``out``, one component-plane in memory at a time."""
    out = Path(out)
    g = fs.grid
    coords = {"t": g.t(), "x": g.x(), "y": g.y(), "z": g.z()}
    ct = max(1, min(g.nt, _CHUNK_BYTES // (4 * g.ny * g.nz)))
    with OutputSet([out], overwrite=req.overwrite) as files, h5py.File(files.temp(out), "w") as h5:
        # HDF5 aborts the process (double free) when it cannot flush on close, e.g. on a full disk:
        # reserve the whole file first, so that ENOSPC comes here, as a Python error, or never
        files.reserve(out, 3 * g.nbytes_per_component() + g.nbytes_per_component() // 32 + (1 << 20))
        for name, value in fs.attrs.items():
            h5.attrs[name] = _attr_value(value)
        h5.attrs["dimension_order"] = DIMENSION_ORDER
        h5.attrs["source_store"] = req.source(fs)
        for name, (unit, long_name) in _COORDS.items():
            d = h5.create_dataset(name, data=coords[name])
            d.attrs.update(units=unit, long_name=long_name)
            d.make_scale(name)
        for c in COMPONENTS:
            d = h5.create_dataset(c, shape=(g.nz, g.ny, g.nx, g.nt), dtype="<f4", chunks=(g.nz, g.ny, 1, ct))
            d.attrs.update(units="m/s", long_name=f"{c} velocity fluctuation", dimension_order=DIMENSION_ORDER)
            for k, name in enumerate("zyxt"):
                d.dims[k].attach_scale(h5[name])
            for ix in range(g.nx):
                d[:, :, ix, :] = fs.read_plane(c, ix).transpose(2, 1, 0)
    lines = ("(HDF5 is not read by InflowWind: use --format wnd/bts/hawc2 for the rotor plane, evo for the lidar simulator)",)
    notes = ["MATLAB: u = h5read(file, '/u') gives (t, x, y, z); h5py gives (z, y, x, t)"]
    return ExportResult((out,), lines, tuple(notes))


def read_hdf5(path) -> dict:
    """Read an export back: u, v, w (nt, nx, ny, nz) float32 [m/s], t [s], x, y, z [m] and attrs (dict)."""
    with h5py.File(path, "r") as h5:
        out = {c: h5[c][...].transpose(3, 2, 1, 0) for c in COMPONENTS}
        out.update({name: h5[name][...] for name in _COORDS})
        out["attrs"] = dict(h5.attrs)
    return out
