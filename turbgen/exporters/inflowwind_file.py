"""A complete InflowWind v5 input file (OpenFAST InflowWind documentation) for an exported wind file.

The v5 parser reads the keys in a fixed order; every section is written (unused ones inert) so the file loads as
is. File names inside are relative to the input file's folder, where InflowWind resolves them."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from turbgen.version import __version__
from turbgen.exporters.request import ifw_line

WIND_TYPES = {2: "uniform wind file", 3: "TurbSim binary .bts", 4: "Bladed-style .wnd + .sum", 5: "HAWC binary"}


@dataclass(frozen=True)
class InflowWindInput:
    """What an InflowWind v5 input file says: ``wind_type`` 2, 3, 4 or 5, hub height [m], U [m/s], the wind files."""

    wind_type: int
    ref_height_m: float
    U_m_s: float
    files: dict
    hawc: dict = field(default_factory=dict)
    ref_length_m: float = 1.0
    title: str = ""


def _rel(path, folder: Path) -> str:
    return Path(os.path.relpath(Path(path).absolute(), folder.absolute())).as_posix()


def inflowwind_text(spec: InflowWindInput, path) -> str:
    """The text of the InflowWind v5 input file to be written at ``path`` (wind-file names relative to its folder)."""
    folder = Path(path).absolute().parent
    files = {k: _rel(v, folder) for k, v in spec.files.items()}
    L = ifw_line
    lines = [
        "------- InflowWind INPUT FILE -------------------------------------------------------------------------",
        (spec.title or f"written by turbgen {__version__}")[:200],
        "---------------------------------------------------------------------------------------------------------------",
        L(False, "Echo", "echo input data to <RootName>.ech (flag)"),
        L(spec.wind_type, "WindType", f"switch for wind file type ({spec.wind_type} = {WIND_TYPES[spec.wind_type]})"),
        L(0.0, "PropagationDir", "direction of wind propagation (deg, meteorological rotation from +X)"),
        L(0.0, "VFlowAng", "upflow angle (deg)"),
        L(False, "VelInterpCubic", "cubic interpolation in time (flag)"),
        L(1, "NWindVel", "number of points to output the wind velocity (0 to 9)"),
        L(0.0, "WindVxiList", "X of the output point (m)"),
        L(0.0, "WindVyiList", "Y of the output point (m)"),
        L(float(spec.ref_height_m), "WindVziList", "Z of the output point: the hub (m)"),
        "================== Parameters for Steady Wind Conditions [used only for WindType = 1] =========================",
        L(float(spec.U_m_s), "HWindSpeed", "horizontal wind speed (m/s)"),
        L(float(spec.ref_height_m), "RefHt", "reference height for horizontal wind speed (m)"),
        L(0.0, "PLExp", "power law exponent (-)"),
        "================== Parameters for Uniform wind file   [used only for WindType = 2] ============================",
        L(files.get("FileName_Uni", "unused.hh"), "FileName_Uni", "uniform wind file (relative to this file)"),
        L(float(spec.ref_height_m), "RefHt_Uni", "reference height for horizontal wind speed (m)"),
        L(float(spec.ref_length_m), "RefLength", "reference length for linear horizontal and vertical shear (m)"),
        "================== Parameters for Binary TurbSim Full-Field files   [used only for WindType = 3] ==============",
        L(files.get("FileName_BTS", "unused.bts"), "FileName_BTS", "TurbSim full-field file (relative to this file)"),
        "================== Parameters for Binary Bladed-style Full-Field files   [used only for WindType = 4 or 7] =====",
        L(files.get("FilenameRoot", "unused"), "FilenameRoot", "root of ROOT.wnd and ROOT.sum (relative to this file)"),
        L(False, "TowerFile", "have tower file (.twr) (flag)"),
        "================== Parameters for HAWC-format binary files  [Only used with WindType = 5] =====================",
        *hawc_lines(files, {"RefHt_HAWC": spec.ref_height_m, **spec.hawc}, spec.U_m_s, " (relative to this file)"),
        "-------------   LIDAR Parameters   --------------------------------------------------------------------------",
        L(0, "SensorType", "0 = none"),
        L(0, "NumPulseGate", "unused"), L(0.0, "PulseSpacing", "unused"), L(0, "NumBeam", "unused"),
        L(0.0, "FocalDistanceX", "unused"), L(0.0, "FocalDistanceY", "unused"), L(0.0, "FocalDistanceZ", "unused"),
        "         0.0, 0.0, 0.0   RotorApexOffsetPos - unused",
        L(float(spec.U_m_s), "URefLid", "unused"), L(0.25, "MeasurementInterval", "unused"),
        L(False, "LidRadialVel", "unused"), L(0, "ConsiderHubMotion", "unused"),
        "====================== OUTPUT ==================================================",
        L(False, "SumPrint", "print summary data to <RootName>.IfW.sum (flag)"),
        "OutList      - the next line(s) list the output channels",
        '"Wind1VelX, Wind1VelY, Wind1VelZ"',
        'END of input file (the word "END" must appear in the first 3 columns of the last OutList line)',
        "---------------------------------------------------------------------------------------",
    ]
    return "\n".join(lines) + "\n"


def hawc_lines(files: dict, hawc: dict, U_m_s: float, where: str = "") -> list[str]:
    """The HAWC-format section, FileName_u to XOffset: ``files`` FileName_u/v/w -> box path (``where`` tells
    relative to what), ``hawc`` nx, ny, nz, dx, dy, dz [m], RefHt_HAWC [m], PLExp_HAWC [-] (inert values where
    missing); ``U_m_s`` URef [m/s]."""
    hw = {"nx": 2, "ny": 2, "nz": 2, "dx": 1.0, "dy": 1.0, "dz": 1.0, "RefHt_HAWC": 0.0, "PLExp_HAWC": 0.0, **hawc}
    L = ifw_line
    return [
        L(files.get("FileName_u", "unused_u.bin"), "FileName_u", f"u - URef{where}"),
        L(files.get("FileName_v", "unused_v.bin"), "FileName_v", f"v{where}"),
        L(files.get("FileName_w", "unused_w.bin"), "FileName_w", f"w{where}"),
        L(int(hw["nx"]), "nx", "number of grids in x (time)"),
        L(int(hw["ny"]), "ny", "number of grids in y"),
        L(int(hw["nz"]), "nz", "number of grids in z"),
        L(float(hw["dx"]), "dx", "distance between x points (m) = URef*dt"),
        L(float(hw["dy"]), "dy", "distance between y points (m)"),
        L(float(hw["dz"]), "dz", "distance between z points (m)"),
        L(float(hw["RefHt_HAWC"]), "RefHt_HAWC", "height of the grid's vertical centre (m)"),
        "-------------   Scaling parameters for turbulence   ---------------------------------------------------------",
        L(0, "ScaleMethod", "0 = no scaling (keeps the mean profile stored in the files)"),
        L(1.0, "SFx", "unused"), L(1.0, "SFy", "unused"), L(1.0, "SFz", "unused"),
        L(0.0, "SigmaFx", "unused"), L(0.0, "SigmaFy", "unused"), L(0.0, "SigmaFz", "unused"),
        "-------------   Mean wind profile parameters (added to HAWC-format files)   ---------------------------------",
        L(float(U_m_s), "URef", "mean u at the reference height (m/s), also the advection speed"),
        L(0, "WindProfile", "0 = constant: the mean profile is already in the files"),
        L(float(hw["PLExp_HAWC"]), "PLExp_HAWC", "unused with WindProfile 0"),
        L(0.03, "Z0", "unused with WindProfile 0"),
        L(0.0, "XOffset", "initial offset in +x (m)"),
    ]


def inflowwind_path(stem_path, fmt: str) -> Path:
    """``<stem>_InflowWind_<fmt>.dat`` beside the wind files (the format keeps exports of one root apart)."""
    p = Path(stem_path)
    return p.with_name(f"{p.name}_InflowWind_{fmt}.dat")


def write_inflowwind(files, path, spec: InflowWindInput) -> str:
    """Write the input file ``path`` through its temporary in the output set ``files``; return its usage line."""
    files.temp(path).write_text(inflowwind_text(spec, path))
    return (f"OpenFAST: set InflowFile = \"{path}\" in the .fst (or run inflowwind_driver on it); its wind-file "
            "names are relative to its own folder")


def hawc2_wind_block(*, paths: dict, folder: Path, U_m_s: float, ti: float, centre_m: float, nt: int, ny: int,
                     nz: int, dx_m: float, dy_m: float, dz_m: float, description: str) -> str:
    """The HAWC2 htc ``begin wind`` block (with ``begin mann``) that loads an export's boxes, which hold u - wsp with
    the mean profile: constant shear, no scaling, box centre at ``centre_m`` [m]."""
    rel = {c: "./" + _rel(p, folder) for c, p in paths.items()}
    return "\n".join([
        f"; {description}",
        "; paste in place of the htc's wind block; the box file names are relative to the folder of this file:",
        "; run HAWC2 in that folder, or prefix them with the path from the folder HAWC2 runs in",
        "begin wind ;",
        "  density 1.225 ;",
        f"  wsp {U_m_s:.10g} ;",
        f"  tint {ti:.6g} ; sigma_u / U of the box (unused: dont_scale 1)",
        "  horizontal_input 1 ;",
        "  windfield_rotations 0.0 0.0 0.0 ; yaw, tilt, rotation",
        f"  center_pos0 0.0 0.0 {-centre_m:.10g} ; box centre: the grid's centre height (z down)",
        "  shear_format 1 0 ; constant: the mean profile is already in the boxes",
        "  turb_format 1 ; Mann boxes",
        "  tower_shadow_method 0 ;",
        "  begin mann ;",
        *(f"    filename_{c} {rel[c]} ;" for c in "uvw"),
        f"    box_dim_u {nt} {dx_m:.10g} ;",
        f"    box_dim_v {ny} {dy_m:.10g} ;",
        f"    box_dim_w {nz} {dz_m:.10g} ;",
        "    dont_scale 1 ;",
        "  end mann ;",
        "end wind ;",
    ]) + "\n"
