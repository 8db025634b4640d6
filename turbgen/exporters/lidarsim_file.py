"""The ``---- Wind Evolution ----`` section of the FUAS lidar-simulator forks' LidarSim input file
(fengguoFUAS / SimonWeichFUAS OpenFAST3.0_LidSim, ``modules/lidarsim``) for an exported ROOT.evo.

The fork reads the section by position: a separator line, ``EvolutionFlag`` (logical), the quoted
``.evo`` path (ROOT.wnd and ROOT.sum beside it), skipping lines that start with ``!``. It opens the path
as written, relative to the folder OpenFAST runs in, so the path is written absolute."""

from __future__ import annotations

from pathlib import Path

from turbgen.exporters.request import ifw_line
from turbgen.version import __version__


def lidarsim_section_path(root) -> Path:
    """``<ROOT>_LidarSim_evolution.txt`` beside the wind files."""
    p = Path(root)
    return p.with_name(f"{p.name}_LidarSim_evolution.txt")


def evolution_section_lines(evo_path) -> tuple[str, ...]:
    """The section's three lines: separator, ``True EvolutionFlag`` and the quoted absolute ``evo_path``."""
    return ("---------------------- Wind Evolution --------------------",
            ifw_line(True, "EvolutionFlag", "flag whether evolution considered: read the 4D field"),
            ifw_line(str(Path(evo_path).absolute()), "EvolutionFilenameRoot",
                     "the .evo file (absolute; ROOT.wnd and ROOT.sum beside it)"))


def write_lidarsim_section(files, path: Path, evo_path) -> str:
    """Write the section file ``path`` through its temporary in ``files``; return its usage line."""
    head = [f"! turbgen {__version__}: the Wind Evolution section of the LidarSim input file (OpenFAST3.0_LidSim forks)",
            "! Paste the lines below in place of that section (the lines after the weighting table, before",
            "! Measurement availability). The fork skips lines starting with '!'. It opens the .evo path as written,",
            "! relative to the folder OpenFAST runs in (not to the LidarSim file): it is written absolute.",
            "! The turbine's InflowWind must use WindType 3 or 4: FilenameRoot = ROOT of the .evo loads ROOT.wnd. The",
            "! export's _InflowWind_evo.dat is in v5 layout; the fork reads the OpenFAST 3.0 one by position: delete",
            "! its VelInterpCubic line and its LIDAR Parameters section there."]
    files.temp(path).write_text("\n".join([*head, *evolution_section_lines(evo_path)]) + "\n")
    return (f"LidarSim (FUAS fork): paste \"{path}\" in place of the Wind Evolution section of the LidarSim input "
            "file (SWELidarFile in the .fst); its .evo path is absolute since the fork resolves it against the "
            "folder OpenFAST runs in")
