"""HAWC2 / Mann binary box (InflowWind WindType 5; the HAWC2 manual's Mann turbulence box, Mann 1998, and
OpenFAST's InflowWind documentation of the HAWC format).

Three headerless little-endian float32 files ROOT_{u,v,w}.bin, nx*ny*nz values, z fastest (bottom up), then y
REVERSED (+W/2 first), then x = time (the first x-plane reaches the turbine first). They hold u - URef, v, w of
the full field, loaded with WindProfile = 0, ScaleMethod = 0, which reproduce it exactly."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from turbgen.exporters.inflowwind_file import (InflowWindInput, hawc2_wind_block, hawc_lines, inflowwind_path,
                                            write_inflowwind)
from turbgen.exporters.outputs import OutputSet
from turbgen.exporters.request import COMPONENTS, ExportRequest, ExportResult, Plane, ifw_line, layout_notes


def component_paths(root) -> dict[str, Path]:
    """{"u": ROOT_u.bin, "v": ROOT_v.bin, "w": ROOT_w.bin}."""
    root = Path(root)
    return {c: root.with_name(f"{root.name}_{c}.bin") for c in COMPONENTS}


def write_hawc2(paths: dict, plane: Plane, U_ref: float) -> None:
    """Write ``plane`` to the boxes ``paths`` {"u", "v", "w": path}: u - ``U_ref`` [m/s], v, w (full velocities)."""
    for c in COMPONENTS:
        with open(paths[c], "wb") as f:
            for a, b in plane.blocks(8 * plane.ny * plane.nz):
                box = plane.full(c, a, b) - (U_ref if c == "u" else 0.0)
                np.ascontiguousarray(box[:, ::-1, :], dtype="<f4").tofile(f)


def read_hawc2(root, shape, U_ref: float) -> dict:
    """Read ROOT_{u,v,w}.bin of ``shape`` (nt, ny, nz) as {"u", "v", "w": float64 [m/s]}, y ascending, u + ``U_ref``."""
    out = {}
    for c, p in component_paths(root).items():
        box = np.fromfile(p, dtype="<f4").reshape(shape)[:, ::-1, :].astype(np.float64)
        out[c] = box + U_ref if c == "u" else box
    return out


def export_hawc2(fs, out, req: ExportRequest) -> ExportResult:
    """Export one plane of store ``fs`` to ROOT_{u,v,w}.bin (``out``: ROOT, or a path ending in .bin)."""
    root = Path(out).with_suffix("") if Path(out).suffix.lower() == ".bin" else Path(out)
    ix, lay = req.plane_index(fs), req.layout(fs)
    g = fs.grid
    paths = component_paths(root)
    dat, htc = inflowwind_path(root, "hawc2"), root.with_name(root.name + "_wind.htc")
    written = (*paths.values(), dat, htc) if req.runner_files else tuple(paths.values())
    usage = []
    with OutputSet(written, overwrite=req.overwrite) as files:
        plane = Plane(fs, ix, lay)
        write_hawc2({c: files.temp(p) for c, p in paths.items()}, plane, fs.U_m_s)
        if req.runner_files:
            usage += runner_files(files, fs, req, plane, lay, paths, dat, htc)
    lines = (ifw_line(5, "WindType", "switch for wind file type (5 = HAWC binary)"),
             ifw_line(0, "PropagationDir", "direction of wind propagation (deg)"),
             *hawc_lines({f"FileName_{c}": p for c, p in paths.items()}, hawc_keys(fs, lay), fs.U_m_s))
    notes = [f"plane x = {g.x_m[ix]:g} m in eddy time; HAWC boxes are always periodic in time",
             "written for InflowWind: the first x-plane reaches the turbine first and u - URef already holds the "
             "shear; in HAWC2 itself switch its shear off and check the box read direction (changed in v13.1)",
             *layout_notes(lay, 0.0, g.nt, g.dt_s)]
    return ExportResult(written, lines, tuple(notes), tuple(usage))


def hawc_keys(fs, lay) -> dict:
    """The HAWC-format keys nx .. PLExp_HAWC of store ``fs`` exported with vertical layout ``lay``."""
    g = fs.grid
    return {"nx": g.nt, "ny": g.ny, "nz": lay.nz, "dx": fs.U_m_s * g.dt_s, "dy": g.dy_m, "dz": g.dz_m,
            "RefHt_HAWC": lay.centre_m, "PLExp_HAWC": lay.shear_exponent}


def runner_files(files, fs, req: ExportRequest, plane: Plane, lay, paths: dict, dat: Path, htc: Path) -> list[str]:
    """Write the InflowWind v5 input file ``dat`` and the HAWC2 wind block ``htc``; one usage line per file."""
    g = fs.grid
    desc = f"turbgen {htc.name}: plane of {req.source(fs)}, {lay.wind.describe()}"
    files_ifw = {f"FileName_{c}": p for c, p in paths.items()}
    usage = [write_inflowwind(files, dat, InflowWindInput(5, lay.hub_height_m, fs.U_m_s, files_ifw, hawc_keys(fs, lay),
                                                          title=desc))]
    ti = float(np.std(plane.fluct["u"], dtype=np.float64)) / fs.U_m_s
    files.temp(htc).write_text(hawc2_wind_block(
        paths=paths, folder=htc.absolute().parent, U_m_s=fs.U_m_s, ti=ti, centre_m=lay.centre_m, nt=g.nt, ny=g.ny,
        nz=lay.nz, dx_m=fs.U_m_s * g.dt_s, dy_m=g.dy_m, dz_m=g.dz_m, description=desc))
    usage.append(f"HAWC2: paste \"{htc}\" in place of the htc's wind block (box names relative to {htc.parent}: run "
                 "HAWC2 there or prefix them; check the box read direction of your HAWC2 version)")
    return usage
