"""Wind files of other tools opened as a one-plane field: a TurbSim ``.bts`` or an htc file's HAWC2 Mann boxes.

A HAWC2 box has no header: size, spacing and wsp come from the htc, the sample interval is dx / wsp (Taylor)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.exporters.bts import read_bts
from turbgen.exporters.request import COMPONENTS
from turbgen.input_files import WIND_FILE, check_input
from turbgen.resources import require_memory

FORMATS = (".bts", ".htc")


def open_wind_file(path):
    """The field of a ``.bts`` or of the boxes of a HAWC2 ``.htc`` as an xarray.Dataset u, v, w (t, x, y, z) [m/s]
    with the ``grid`` and ``U_m_s`` attributes of a store (one plane at x = 0); ParameterError for another suffix,
    an unreadable file or htc, or boxes whose size disagrees with the htc."""
    p = Path(path).expanduser()
    if p.suffix.lower() not in FORMATS:
        raise ParameterError(f"{p}: a wind file must end in {' or '.join(FORMATS)}")
    if p.suffix.lower() == ".bts":
        raw = read_bts(_checked(p, 5))
        fields = {c: raw[c] for c in COMPONENTS}
        dt, U, dy, dz = raw["dt_s"], raw["U_m_s"], _step(raw["y"]), _step(raw["z"])
    else:
        fields, dt, U, dy, dz = _hawc2_boxes(p)
    return _dataset(fields, dt, U, dy, dz, str(p))


def _checked(p: Path, expansion: int) -> Path:
    """``p`` after the input-file rules and a memory check for its values read as float64 (``expansion`` x size)."""
    check_input(p, WIND_FILE)
    require_memory(expansion * p.stat().st_size, f"reading {p}", "fit a shorter record or fewer points")
    return p


def _step(axis: np.ndarray) -> float:
    return float(axis[1] - axis[0]) if axis.size > 1 else 1.0


def _hawc2_boxes(htc: Path):
    text = check_input(htc, WIND_FILE).read_text(errors="replace")
    block = re.search(r"begin\s+mann\s*;(.*?)end\s+mann\s*;", text, re.S | re.I)
    wsp = re.search(r"^\s*wsp\s+([-+0-9.eE]+)", text, re.M | re.I)
    if block is None or wsp is None:
        raise ParameterError(f"{htc}: no 'begin mann ... end mann' block with a 'wsp' in its wind block")
    entries = {m[0].lower(): m[1].split() for m in re.findall(r"^\s*(\w+)\s+([^;]*);", block[1], re.M)}
    try:
        dims = [(int(entries[f"box_dim_{c}"][0]), float(entries[f"box_dim_{c}"][1])) for c in COMPONENTS]
        names = {c: entries[f"filename_{c}"][0] for c in COMPONENTS}
        U = float(wsp[1])
    except (KeyError, IndexError, ValueError):
        raise ParameterError(f"{htc}: its mann block needs filename_u/v/w and box_dim_u/v/w 'n spacing'") from None
    if U <= 0 or min(n for n, _ in dims) < 1 or min(d for _, d in dims) <= 0:
        raise ParameterError(f"{htc}: wsp = {U:g} m/s and the box sizes and spacings must be positive")
    shape = tuple(n for n, _ in dims)
    fields = {}
    for c in COMPONENTS:
        # HAWC2 resolves the names from the folder it runs in: the htc's own, or (htc/ layout) its parent
        where = [f / names[c] for f in (htc.parent, htc.parent.parent)]
        found = next((f for f in where if f.is_file()), None)
        if found is None:
            raise ParameterError(f"{htc}: box file {names[c]} is in neither {where[0].parent} nor {where[1].parent}")
        box = np.fromfile(_checked(found, 2), dtype="<f4")
        if box.size != np.prod(shape):
            raise ParameterError(f"{found}: {box.size} values, but the htc's box_dim_u/v/w give {shape}")
        fields[c] = box.reshape(shape)[:, ::-1, :]  # y stored reversed (turbgen.exporters.hawc2)
    return fields, dims[0][1] / U, U, dims[1][1], dims[2][1]


def _dataset(fields: dict, dt: float, U: float, dy: float, dz: float, source: str):
    import xarray as xr

    nt, ny, nz = fields["u"].shape
    grid = {"nt": nt, "dt_s": float(dt), "x_m": [0.0], "ny": ny, "nz": nz, "dy_m": dy, "dz_m": dz}
    ds = xr.Dataset({c: (("t", "x", "y", "z"), np.asarray(fields[c], np.float32)[:, None]) for c in COMPONENTS},
                    coords={"t": dt * np.arange(nt), "x": [0.0]}, attrs={"grid": grid, "U_m_s": float(U)})
    ds.encoding["source"] = source
    return ds
