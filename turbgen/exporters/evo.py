"""The 4D lidar-simulator set ROOT.evo + ROOT.wnd + ROOT.sum, as read by the LidarSim ``.evo`` reader of the
FUAS OpenFAST3.0_LidSim forks (evoTurb, Guo et al. 2022).

ROOT.evo, little-endian int16: NL (<= 30), NL plane distances in whole metres (positive upstream), then per
plane, time step, z (bottom up), y (from -W/2) the components u, v, w (fastest): the simulator's READER order.
V = U (o + 1e-5 TI% raw) with U and TI from the ROOT.wnd header (which carries the rotor plane for InflowWind).
The stored t axis is the simulator's "eddy index" time axis."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.exporters.inflowwind_file import inflowwind_path
from turbgen.exporters.lidarsim_file import evolution_section_lines, lidarsim_section_path, write_lidarsim_section
from turbgen.exporters.outputs import OutputSet
from turbgen.exporters.request import ExportRequest, ExportResult, Plane, layout_notes
from turbgen.exporters.wnd import (BladedStats, WndHeader, bladed_raw, check_even_nt, export_root, from_bladed,
                                inflowwind_lines, read_wnd, root_file, write_pair, write_wnd_inflowwind)

MAX_PLANES = 30  # the reader copies the distances into a fixed 30-element buffer


def plane_distances(x_m) -> tuple[np.ndarray, list[str]]:
    """Plane distances ``x_m`` [m] as int16 whole metres and an ``"x->r"`` note per rounded one; ParameterError
    for more than ``MAX_PLANES`` planes, a distance beyond +-32767 m, or planes merging on rounding."""
    x = np.asarray(x_m, dtype=float)
    if len(x) > MAX_PLANES:
        raise ParameterError(f"{len(x)} planes: the lidar simulator's .evo reader holds at most {MAX_PLANES}")
    r = np.rint(x)
    if np.abs(r).max() > 32767:
        raise ParameterError(f"plane positions {x.tolist()} m exceed the .evo int16 range +-32767 m")
    if len(set(r.tolist())) != len(r):
        raise ParameterError(f"plane positions {x.tolist()} m coincide when rounded to the .evo's whole metres")
    rounded = [f"{v:g}->{rv:g}" for v, rv in zip(x, r) if abs(v - rv) > 1e-9]
    return r.astype("<i2"), rounded


def export_evo(fs, out, req: ExportRequest) -> ExportResult:
    """Export every plane of ``fs`` to ROOT.evo, and one plane (default the rotor) to ROOT.wnd / ROOT.sum, in two passes
    with one plane in memory: one TI scaling that fits every plane, then the planes."""
    root = export_root(out)
    ix_rotor, lay = req.plane_index(fs), req.layout(fs)
    g = fs.grid
    check_even_nt(g.nt)
    dist, rounded = plane_distances(g.x_m)
    paths = [root_file(root, ".evo"), root_file(root, ".wnd"), root_file(root, ".sum")]
    if req.runner_files:
        paths += [inflowwind_path(root, "evo"), lidarsim_section_path(root)]
    shift = req.start_shift_s(fs)
    usage = []
    with OutputSet(paths, overwrite=req.overwrite) as files:
        stats = BladedStats()
        for ix in range(g.nx):  # pass 1: one TI scaling that fits every plane
            stats.add(Plane(fs, ix, lay, -shift), fs.U_m_s)
        header = WndHeader(nz=lay.nz, ny=g.ny, nt=g.nt, dz_m=g.dz_m, dy_m=g.dy_m, dx_m=fs.U_m_s * g.dt_s,
                           U_m_s=fs.U_m_s, ti_percent=stats.ti_percent(fs.U_m_s), zref_m=lay.centre_m)
        with open(files.temp(paths[0]), "wb") as f:
            f.write(np.asarray([len(dist)], dtype="<i2").tobytes() + dist.tobytes())
            for ix in range(g.nx):  # pass 2: plane, time, z, y, component
                plane = Plane(fs, ix, lay, -shift)
                for a, b in plane.blocks(8 * plane.ny * plane.nz):
                    f.write(np.ascontiguousarray(bladed_raw(plane, a, b, header.U_m_s, header.ti_percent)).tobytes())
                if ix == ix_rotor:
                    write_pair(files, root, plane, header, lay, periodic=req.periodic,
                               title=f"turbgen 4D export: the .wnd holds plane x = {g.x_m[ix]:g} m"
                               + ("" if lay.mean_wind is None else f", {lay.wind.describe()}"))
                del plane  # free it before the next plane is read
        if req.runner_files:
            usage += [write_wnd_inflowwind(files, paths[3], root, lay, fs.U_m_s, x_m=g.x_m[ix_rotor], shift_s=shift),
                      write_lidarsim_section(files, paths[4], paths[0])]
    lines = inflowwind_lines(root) + ("LidarSim input file, section ---- Wind Evolution ----:",
                                      *evolution_section_lines(paths[0]))
    notes = [f"ROOT.evo holds {g.nx} planes at {dist.tolist()} m upstream (the simulator picks the nearest to -X, "
             "X measured from the tower axis)",
             f"ROOT.wnd holds plane x = {g.x_m[ix_rotor]:g} m; the turbine's InflowWind must use WindType 3 or 4",
             *layout_notes(lay, shift, g.nt, g.dt_s)]
    if rounded:
        notes.append(f"plane distances rounded to the .evo's whole metres: {', '.join(rounded)} m "
                     "(the simulator samples the stored eddy-time series of the nearest plane)")
    return ExportResult(tuple(paths), lines, tuple(notes), tuple(usage))


def read_evo(path) -> dict:
    """Read ROOT.evo (header from ROOT.wnd): x_up (NL,) [m] upstream and u, v, w (NL, nt, ny, nz) [m/s]."""
    path = Path(path)
    h = read_wnd(path.with_suffix(".wnd"))["header"]
    raw = np.fromfile(path, dtype="<i2")
    nl = int(raw[0])
    data = raw[1 + nl:].reshape(nl, h.nt, h.nz, h.ny, 3).transpose(0, 1, 3, 2, 4)
    return from_bladed(data, h.U_m_s, h.ti_percent) | {"x_up": raw[1:1 + nl].astype(float)}
