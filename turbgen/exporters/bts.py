"""TurbSim binary full-field ``.bts`` (InflowWind WindType 3; Jonkman 2009, TurbSim User's Guide v1.50,
NREL/TP-500-46198, binary full-field appendix).

Layout: 70-byte header ``<h4i6f6fi`` + description, then per time step ny*nz*3 int16, component fastest, then y
(from -W/2, +y left looking downwind), then z (from the bottom), then ntwr*3 int16 tower points; V = (raw -
offset) / slope per component."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from turbgen.version import __version__
from turbgen.exporters.inflowwind_file import InflowWindInput, inflowwind_path, write_inflowwind
from turbgen.exporters.outputs import OutputSet
from turbgen.exporters.request import COMPONENTS, ExportRequest, ExportResult, Plane, ifw_line, layout_notes

_HEADER = struct.Struct("<h4i6f6fi")


def int16_scaling(vmin: float, vmax: float) -> tuple[float, float]:
    """TurbSim's float32 int16 scaling ``(slope, offset)``: raw = slope v + offset spans the int16 range for v
    in [vmin, vmax] [m/s]."""
    slope = 65535.0 / (vmax - vmin) if vmax > vmin else 1.0
    slope = float(np.float32(slope))
    return slope, float(np.float32(-32768.0 - slope * vmin))


def quantise(values: np.ndarray, slope: float, offset: float) -> np.ndarray:
    """Little-endian int16 rint(values*slope + offset) clipped to [-32768, 32767], for velocities [m/s]."""
    return np.clip(np.rint(values * slope + offset), -32768, 32767).astype("<i2")


def tower_heights(bottom_m: float, dz_m: float) -> np.ndarray:
    """Tower point heights [m]: ``bottom_m``, bottom - dz, ... while above the ground."""
    n = int(np.ceil(bottom_m / dz_m - 1e-6))
    return bottom_m - dz_m * np.arange(max(n, 0))


def write_bts(path, plane: Plane, *, dy_m, dz_m, dt_s, U_m_s, hub_height_m, bottom_m, periodic: bool,
              description: str, tower: dict | None = None) -> None:
    """Write ``plane`` (full velocities) and optional ``tower`` points to ``path``; one int16 scale per component."""
    nt, ny, nz = plane.nt, plane.ny, plane.nz
    ntwr = 0 if tower is None else tower["u"].shape[1]
    blocks = plane.blocks(8 * ny * nz)
    scaling = []
    for c in COMPONENTS:  # TurbSim: one scaling per component over grid and tower points
        lo, hi = np.inf, -np.inf
        for a, b in blocks:
            v = plane.full(c, a, b)
            lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
        if ntwr:
            lo, hi = min(lo, float(tower[c].min())), max(hi, float(tower[c].max()))
        scaling.append(int16_scaling(lo, hi))
    text = description.encode("ascii", "replace")
    header = _HEADER.pack(8 if periodic else 7, nz, ny, ntwr, nt, dz_m, dy_m, dt_s, U_m_s, hub_height_m, bottom_m,
                          *[s for pair in scaling for s in pair], len(text))
    with open(path, "wb") as f:
        f.write(header + text)
        for a, b in blocks:
            grid = np.stack([quantise(plane.full(c, a, b), *s) for c, s in zip(COMPONENTS, scaling)], axis=-1)
            block = grid.transpose(0, 2, 1, 3).reshape(b - a, -1)  # (t, z, y, component)
            if ntwr:
                twr = np.stack([quantise(tower[c][a:b], *s) for c, s in zip(COMPONENTS, scaling)], axis=-1)
                block = np.concatenate([block, twr.reshape(b - a, -1)], axis=1)
            f.write(np.ascontiguousarray(block).tobytes())


def read_bts(path) -> dict:
    """Read a ``.bts`` back: u, v, w (nt, ny, nz) [m/s]; y (ny,) [m] centred, z (nz,) heights [m]; dt_s [s], U_m_s
    [m/s], hub_height_m [m], periodic, id, description, tower_z (ntwr,) [m], tower_u/v/w (nt, ntwr) [m/s]."""
    raw = Path(path).read_bytes()
    (ident, nz, ny, ntwr, nt, dz, dy, dt, uhub, zhub, zbot, *rest) = _HEADER.unpack_from(raw, 0)
    scaling, nchar = rest[:6], rest[6]
    start = _HEADER.size + nchar
    data = np.frombuffer(raw, dtype="<i2", count=nt * (ny * nz + ntwr) * 3, offset=start).reshape(nt, -1)
    grid = data[:, : ny * nz * 3].reshape(nt, nz, ny, 3).transpose(0, 2, 1, 3)
    twr = data[:, ny * nz * 3:].reshape(nt, ntwr, 3)
    out = {"dt_s": dt, "U_m_s": uhub, "hub_height_m": zhub, "periodic": ident == 8, "id": ident,
           "description": raw[_HEADER.size:start].decode("ascii"),
           "y": (np.arange(ny) - (ny - 1) / 2) * dy, "z": zbot + dz * np.arange(nz),
           "tower_z": zbot - dz * np.arange(ntwr)}
    for k, c in enumerate(COMPONENTS):
        slope, off = scaling[2 * k], scaling[2 * k + 1]
        out[c] = (grid[..., k] - off) / slope
        out[f"tower_{c}"] = (twr[..., k] - off) / slope
    return out


def tower_values(plane: Plane, heights_m: np.ndarray, layout, U_m_s: float) -> dict:
    """Tower-point velocities {"u", "v", "w": (nt, ntwr) [m/s]} at ``heights_m``: the mean wind plus the lowest
    grid row's fluctuations at y = 0; ParameterError when the profile does not cover them."""
    cols = [(plane.ny - 1) // 2, plane.ny // 2]  # y = 0 is the centre column, or midway between two
    out = {}
    for c in COMPONENTS:
        fluct = 0.5 * (plane.fluct[c][:, cols[0], 0].astype(np.float64) + plane.fluct[c][:, cols[1], 0])
        out[c] = np.repeat(fluct[:, None], len(heights_m), axis=1)
    if not plane.varying:
        out["u"] += layout.mean_u(U_m_s, heights_m)[None, :]
    else:
        out["u"], out["v"] = layout.wind.full_uv(out["u"], out["v"], plane.times_s[:, None], 0.0, heights_m[None, :],
                                                 U_m_s, layout.hub_height_m)  # the tower stands at y = 0
    return out


def export_bts(fs, out, req: ExportRequest) -> ExportResult:
    """Export one plane of store ``fs`` to the ``.bts`` file ``out`` (errors: :func:`export_store`)."""
    out = Path(out)
    ix, lay = req.plane_index(fs), req.layout(fs)
    g = fs.grid
    dat = inflowwind_path(out.with_suffix("") if out.suffix.lower() == ".bts" else out, "bts")
    usage = []
    with OutputSet([out, dat] if req.runner_files else [out], overwrite=req.overwrite) as files:
        shift = req.start_shift_s(fs)
        plane = Plane(fs, ix, lay, -shift)
        tower = tower_values(plane, tower_heights(lay.bottom_m, g.dz_m), lay, fs.U_m_s) if req.tower else None
        source = f"turbgen {__version__} from {req.source(fs)} ({fs.model}, seed {fs.attrs.get('seed')})"
        if lay.mean_wind is None and not shift:  # the description of earlier versions, byte for byte
            desc = f"Generated by {source}, plane x = {g.x_m[ix]:g} m, {lay.wind.describe()}"
        else:  # what InflowWind users need first, before the (possibly long, truncated) source path
            desc = (f"NOT PERIODIC: starts {shift:.6g} s upstream (InitX/U). " if shift else "") + \
                f"Mean wind: {lay.wind.describe()}. Plane x = {g.x_m[ix]:g} m. Generated by {source}"
        write_bts(files.temp(out), plane, dy_m=g.dy_m, dz_m=g.dz_m, dt_s=g.dt_s, U_m_s=fs.U_m_s,
                  hub_height_m=lay.hub_height_m, bottom_m=lay.bottom_m, periodic=req.periodic,
                  description=desc[:200], tower=tower)
        if req.runner_files:
            usage.append(write_inflowwind(files, dat, InflowWindInput(
                3, lay.hub_height_m, fs.U_m_s, {"FileName_BTS": out}, title=desc)))
    lines = (ifw_line(3, "WindType", "switch for wind file type (3 = TurbSim binary .bts)"),
             ifw_line(0, "PropagationDir", "direction of wind propagation (deg)"),
             ifw_line(str(out), "FileName_BTS", "TurbSim binary full-field file"))
    notes = [f"plane x = {g.x_m[ix]:g} m in eddy time: slice k is stored t index k (t = k*{g.dt_s:g} s)",
             *layout_notes(lay, shift, g.nt, g.dt_s)]
    if req.tower:
        notes.append("tower points: the mean wind plus the lowest row's fluctuations at y = 0 (held constant below the grid)")
    return ExportResult((out, dat) if req.runner_files else (out,), lines, tuple(notes), tuple(usage))
