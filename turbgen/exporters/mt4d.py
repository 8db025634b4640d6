"""``.mt4d``: the headerless float32 layout of the 4D Mann turbulence generator
(MSCA-LIKE/4D-Mann-Turbulence-Generator, its MannTurb4D writer; Guo et al. 2022).

Fortran order z fastest, then y, then x, then snapshot slot, then component (u, v, w): MATLAB
``reshape(data, [nz ny n1 nslots 3])``. Slot k = plane k (slot time t_k = x_k / U); the box's x axis is
eddy time REVERSED (x increases downwind: box x index i holds stored t index nt-1-i); y and z ascending
(+y left, z relative to the hub). Fluctuations only (no mean, no shear), as the generator writes them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from turbgen.exporters.outputs import OutputSet
from turbgen.exporters.request import COMPONENTS, ExportRequest, ExportResult


def export_mt4d(fs, out, req: ExportRequest) -> ExportResult:
    """Export every plane of ``fs`` to the ``.mt4d`` file ``out``; the notes give the MATLAB ``reshape`` call."""
    out = Path(out)
    g = fs.grid
    with OutputSet([out], overwrite=req.overwrite) as files, open(files.temp(out), "wb") as f:
        for c in COMPONENTS:
            for ix in range(g.nx):
                np.ascontiguousarray(fs.read_plane(c, ix)[::-1], dtype="<f4").tofile(f)
    slots = ", ".join(f"{x / fs.U_m_s:g}" for x in g.x_m)
    lines = ("(.mt4d is not read by InflowWind: use --format wnd/bts/hawc2 for the rotor plane, evo for the lidar simulator)",)
    notes = [f"n1 (x = reversed eddy time) = {g.nt}, n2 = {g.ny}, n3 = {g.nz}, Nt (slots = planes) = {g.nx}; "
             f"Lx = {g.nt * fs.U_m_s * g.dt_s:g} m, Ly = {g.ny * g.dy_m:g} m, Lz = {g.nz * g.dz_m:g} m",
             f"slot times t_k = x_k/U = [{slots}] s for planes x = {list(g.x_m)} m",
             f"MATLAB: reshape(fread(fid, inf, 'float32'), [{g.nz} {g.ny} {g.nt} {g.nx} 3])"]
    return ExportResult((out,), lines, tuple(notes))


def read_mt4d(path, shape) -> dict:
    """Read an ``.mt4d`` of store ``shape`` (nt, nx, ny, nz) as {"u", "v", "w": float32 (nt, nx, ny, nz) [m/s]}."""
    nt, nx, ny, nz = shape
    data = np.fromfile(path, dtype="<f4").reshape(3, nx, nt, ny, nz)
    return {c: data[k, :, ::-1].transpose(1, 0, 2, 3) for k, c in enumerate(COMPONENTS)}
