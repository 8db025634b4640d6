"""Bladed-style ``.wnd`` + TurbSim-style ``.sum`` (InflowWind WindType 4; Jonkman 2009, TurbSim User's Guide
v1.50, and OpenFAST's InflowWind documentation); the same pair carries the header for the lidar simulator's
``.evo`` (turbgen.exporters.evo).

``.wnd``: 104-byte header (ID -99, TurbType 4), then per time step nz*ny*3 int16, component fastest, then y
(from -W/2, +y left), then z (from the bottom); V = U (o + 1e-5 TI% raw), o = (1, 0, 0). No Bladed left-hand
rule: v has InflowWind's sign (the lidar simulator's ``.evo`` reader never negates v either)."""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.exporters.inflowwind_file import InflowWindInput, inflowwind_path, write_inflowwind
from turbgen.exporters.outputs import OutputSet
from turbgen.exporters.request import COMPONENTS, ExportRequest, ExportResult, Plane, ifw_line, layout_notes
from turbgen.exporters.wnd_summary import sum_text

_HEADER = struct.Struct("<hhi6f3fi4f4i6f")
_OFFSET = {"u": 1.0, "v": 0.0, "w": 0.0}
_RAW_LIMIT = 32000.0  # keeps |raw| below the int16 limit with margin


class BladedStats:
    """Running per-component largest |V - U o| and fluctuation variance, which fix the Bladed TI scaling."""

    def __init__(self):
        self.maxdev = dict.fromkeys(COMPONENTS, 0.0)
        self.sums = {c: [0, 0.0, 0.0] for c in COMPONENTS}

    def add(self, plane: Plane, U_m_s: float) -> None:
        """Include one plane: the largest |full velocity - U*o| and the fluctuations' running sums per component."""
        for c in COMPONENTS:
            s = self.sums[c]
            for a, b in plane.blocks(8 * plane.ny * plane.nz):
                dev = np.abs(plane.full(c, a, b) - U_m_s * _OFFSET[c]).max()
                self.maxdev[c] = max(self.maxdev[c], float(dev))
                fluct = plane.fluct[c][a:b].astype(np.float64)
                s[0] += fluct.size
                s[1] += float(fluct.sum())
                s[2] += float(np.square(fluct).sum())

    def ti_percent(self, U_m_s: float) -> tuple[float, float, float]:
        """TI of u, v, w [%]: sigma/U, enlarged so every raw value fits in +-32000, >= 1e-3 %, as float32."""
        out = []
        for c in COMPONENTS:
            n, s1, s2 = self.sums[c]
            sigma = np.sqrt(max(s2 / n - (s1 / n) ** 2, 0.0))
            ti = max(100.0 * sigma / U_m_s, self.maxdev[c] * 1e5 / (U_m_s * _RAW_LIMIT), 1e-3)
            out.append(float(np.float32(ti)))  # the header's float32 value, used by every reader
        return tuple(out)


def bladed_raw(plane: Plane, a: int, b: int, U_m_s: float, ti: tuple) -> np.ndarray:
    """Int16 block (b - a, nz, ny, 3) of time steps a..b-1: raw = (V / U - o) 1e5 / TI% [``ti``], saturated."""
    raw = [np.clip(np.rint((plane.full(c, a, b) / U_m_s - _OFFSET[c]) * 1e5 / t), -32768, 32767)
           for c, t in zip(COMPONENTS, ti)]
    return np.stack(raw, axis=-1).astype("<i2").transpose(0, 2, 1, 3)


def from_bladed(raw: np.ndarray, U_m_s: float, ti: tuple) -> dict:
    """Velocities {"u", "v", "w": float64 [m/s]} from raw int16 (..., 3): V = U (o + 1e-5 TI% raw)."""
    return {c: U_m_s * (_OFFSET[c] + 1e-5 * t * raw[..., k]) for k, (c, t) in enumerate(zip(COMPONENTS, ti))}


@dataclass(frozen=True)
class WndHeader:
    """The grid and scaling of a ``.wnd`` (dz, dy, dx [m], nt, U [m/s], TI [%], nz, ny)."""

    nz: int
    ny: int
    nt: int
    dz_m: float
    dy_m: float
    dx_m: float
    U_m_s: float
    ti_percent: tuple
    zref_m: float = 0.0

    def pack(self) -> bytes:
        """The 104-byte header: ID -99, TurbType 4, 3 components, zref, TI, dz, dy, dx, nt/2, U, nz, ny."""
        return _HEADER.pack(-99, 4, 3, 0.0, 0.0, self.zref_m, *self.ti_percent, self.dz_m, self.dy_m, self.dx_m,
                            self.nt // 2, self.U_m_s, 0.0, 0.0, 0.0, 0, 0, self.nz, self.ny, *([0.0] * 6))

    @classmethod
    def unpack(cls, raw: bytes) -> "WndHeader":
        """Header from the first 104 bytes of a ``.wnd``; ParameterError if not ID -99, TurbType 4."""
        h = _HEADER.unpack_from(raw, 0)
        if h[0] != -99 or h[1] != 4:
            raise ParameterError(f"not a new-style TurbType-4 .wnd (ID {h[0]}, type {h[1]})")
        return cls(nz=h[19], ny=h[20], nt=2 * h[12], dz_m=h[9], dy_m=h[10], dx_m=h[11], U_m_s=h[13],
                   ti_percent=tuple(h[6:9]), zref_m=h[5])


def write_wnd(path, plane: Plane, header: WndHeader) -> None:
    """Write the ``.wnd`` at ``path``: the header, then the time steps of ``plane``."""
    with open(path, "wb") as f:
        f.write(header.pack())
        for a, b in plane.blocks(8 * plane.ny * plane.nz):
            f.write(np.ascontiguousarray(bladed_raw(plane, a, b, header.U_m_s, header.ti_percent)).tobytes())


def read_wnd(path) -> dict:
    """Read a ``.wnd``: {"u", "v", "w": float64 (nt, ny, nz) [m/s], "header": :class:`WndHeader`}."""
    raw = Path(path).read_bytes()
    h = WndHeader.unpack(raw)
    data = np.frombuffer(raw, dtype="<i2", offset=_HEADER.size).reshape(-1, h.nz, h.ny, 3)
    return from_bladed(data.transpose(0, 2, 1, 3), h.U_m_s, h.ti_percent) | {"header": h}


def check_even_nt(nt: int) -> None:
    """Refuse an odd ``nt`` (ParameterError): the .wnd header stores nt/2 and readers take nt = 2 * nt/2."""
    if nt % 2:
        raise ParameterError(f"nt = {nt} is odd; the .wnd header stores nt/2, so the Bladed/evo export needs an even nt")


def write_pair(files: OutputSet, root: Path, plane: Plane, header: WndHeader, lay, *, periodic: bool, title: str) -> None:
    """Write ROOT.wnd and ROOT.sum (hub height and offset from ``lay``) through the temporaries of ``files``."""
    write_wnd(files.temp(root_file(root, ".wnd")), plane, header)
    files.temp(root_file(root, ".sum")).write_text(sum_text(
        hub_height_m=lay.hub_height_m, U_m_s=header.U_m_s, ti_percent=header.ti_percent,
        height_offset_m=lay.hub_height_m - lay.centre_m, periodic=periodic, title=title))


def inflowwind_lines(root: Path) -> tuple[str, ...]:
    """WindType 4 InflowWind lines for FilenameRoot ``root`` (TowerFile False: no ROOT.twr)."""
    return (ifw_line(4, "WindType", "switch for wind file type (4 = Bladed-style .wnd + .sum)"),
            ifw_line(0, "PropagationDir", "direction of wind propagation (deg)"),
            ifw_line(str(root), "FilenameRoot", "root of ROOT.wnd and ROOT.sum"),
            ifw_line(False, "TowerFile", "no ROOT.twr"))


def write_wnd_inflowwind(files: OutputSet, path: Path, root: Path, lay, U_m_s: float, *, x_m: float,
                         shift_s: float) -> str:
    """Write the InflowWind v5 input file ``path`` (WindType 4, FilenameRoot ``root``); return its usage line."""
    title = f"turbgen {root.name}.wnd: plane x = {x_m:g} m, {lay.wind.describe()}"
    title = (f"NOT PERIODIC: starts {shift_s:.6g} s upstream (InitX/U). " if shift_s else "") + title
    return write_inflowwind(files, path, InflowWindInput(4, lay.hub_height_m, U_m_s, {"FilenameRoot": root},
                                                        title=title))


def root_file(root: Path, ext: str) -> Path:
    """ROOT + ``ext`` (".wnd"), appended: ``with_suffix`` would turn ``case_U16.5`` into ``case_U16.wnd``."""
    return root.with_name(root.name + ext)


def export_root(out) -> Path:
    """``out`` without a .wnd, .sum or .evo extension (any case)."""
    out = Path(out)
    return out.with_suffix("") if out.suffix.lower() in (".wnd", ".sum", ".evo") else out


def export_wnd(fs, out, req: ExportRequest) -> ExportResult:
    """Export one plane of store ``fs`` to ROOT.wnd + ROOT.sum (``out``: ROOT, or ROOT.wnd/.sum/.evo)."""
    root = export_root(out)
    ix, lay = req.plane_index(fs), req.layout(fs)
    g = fs.grid
    check_even_nt(g.nt)
    paths = [root_file(root, ".wnd"), root_file(root, ".sum")]
    if req.runner_files:
        paths.append(inflowwind_path(root, "wnd"))
    usage = []
    with OutputSet(paths, overwrite=req.overwrite) as files:
        shift = req.start_shift_s(fs)
        plane = Plane(fs, ix, lay, -shift)
        stats = BladedStats()
        stats.add(plane, fs.U_m_s)
        header = WndHeader(nz=lay.nz, ny=g.ny, nt=g.nt, dz_m=g.dz_m, dy_m=g.dy_m, dx_m=fs.U_m_s * g.dt_s,
                           U_m_s=fs.U_m_s, ti_percent=stats.ti_percent(fs.U_m_s), zref_m=lay.centre_m)
        write_pair(files, root, plane, header, lay, periodic=req.periodic,
                   title=f"turbgen export: plane x = {g.x_m[ix]:g} m, {lay.wind.describe()}")
        if req.runner_files:
            usage.append(write_wnd_inflowwind(files, paths[2], root, lay, fs.U_m_s, x_m=g.x_m[ix], shift_s=shift))
    notes = [f"plane x = {g.x_m[ix]:g} m in eddy time: slice k is stored t index k",
             *layout_notes(lay, shift, g.nt, g.dt_s)]
    return ExportResult(tuple(paths), inflowwind_lines(root), tuple(notes), tuple(usage))
