"""TurbSim-style ``.sum`` of a ``.wnd`` export (Jonkman 2009, TurbSim User's Guide v1.50): the lines InflowWind v5
and the lidar-simulator forks parse for WindType 4, written and read back in their order."""

from __future__ import annotations

import re
from pathlib import Path

from turbgen.exporters.request import COMPONENTS


def sum_text(*, hub_height_m: float, U_m_s: float, ti_percent, height_offset_m: float, periodic: bool,
             title: str) -> str:
    """The ``.sum`` text: title, CLOCKWISE (F; the forks need it before the hub height), hub height [m], UBar
    [m/s], TI [%], height offset [m] (hub minus grid centre), PERIODIC when ``periodic``; keys in ``title`` defused."""
    lines = [_defuse(title),  # free text: must not contain the keys parsed below
             "",
             "         F  Clockwise rotation when looking downwind?",
             f"{hub_height_m:12.4f}  Hub height [m]",
             f"   UBar  = {U_m_s:12.6f} m/s",
             *[f"   TI({c}) = {t:12.6f} %" for c, t in zip(COMPONENTS, ti_percent)],
             f"   Height Offset = {height_offset_m:12.6f} m"]
    if periodic:
        lines.append("Creating a PERIODIC output file.")
    return "\n".join(lines) + "\n"


_KEYS = ("HUB HEIGHT", "ZHUB", "UBAR", "CLOCKWISE", "HEIGHT OFFSET", "PERIODIC", "BLADED LEFT-HAND RULE")


def _defuse(title: str) -> str:
    """``title`` with every parsed key (any case) broken by a hyphen after its first letter."""
    for key in _KEYS:
        title = re.sub(re.escape(key), lambda m: m[0][0] + "-" + m[0][1:], title, flags=re.IGNORECASE)
    return title


def read_sum(path) -> dict:
    """Parse a ``.sum`` as InflowWind does (keys in order): clockwise, hub_height_m [m], U_m_s [m/s], ti_percent
    (3) [%], height_offset_m [m] (0 when absent), periodic; IndexError/ValueError for a missing or malformed key."""
    lines = Path(path).read_text().upper().splitlines()
    out = {"clockwise": False, "height_offset_m": 0.0, "periodic": False}
    i = 0
    while "HUB HEIGHT" not in lines[i] and "ZHUB" not in lines[i]:
        if "CLOCKWISE" in lines[i]:
            out["clockwise"] = lines[i].split()[0] in ("T", "Y", "TRUE")
        i += 1
    out["hub_height_m"] = float(lines[i].split()[0])
    while "UBAR" not in lines[i]:
        i += 1
    out["U_m_s"] = float(lines[i].split("=")[1].split()[0])
    out["ti_percent"] = tuple(float(re.search(r"=(.*)%", lines[i + k]).group(1)) for k in (1, 2, 3))
    for j in range(i + 4, len(lines)):
        if "HEIGHT OFFSET" in lines[j]:
            out["height_offset_m"] = float(lines[j].split("=")[1].split()[0])
            out["periodic"] = any("PERIODIC" in line for line in lines[j + 1:])
    return out
