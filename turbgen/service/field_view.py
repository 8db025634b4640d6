"""The field as the run's page shows it, cached products of a complete store: a point's u, v, w series (JSON) and
a yz snapshot (PNG, +- 3 sigma of the run so frames compare, a constrained field's measurement points marked)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError

MAX_SERIES_SAMPLES = 65536
COMPONENTS = ("u", "v", "w")


def check_index(name: str, value: int, size: int) -> int:
    """``value`` if it indexes an axis ``name`` of ``size`` entries, else a ParameterError naming it and the range."""
    if not 0 <= value < size:
        raise ParameterError(f"{name} = {value} is outside [0, {size - 1}]")
    return value


def build_series(store: Path, plane: int, iy: int, iz: int, tmp: Path) -> None:
    """u, v, w at grid point (plane, iy, iz) of ``store`` as JSON into the new file ``tmp``: ``x_m``, ``y_m``, ``z_m``
    [m], ``dt_s`` [s], ``step``, ``nt`` and ``u``, ``v``, ``w`` [m/s] (every ``step``-th of MAX_SERIES_SAMPLES+)."""
    from turbgen.store import open_store

    fs = open_store(store)
    g = fs.grid
    step = -(-g.nt // MAX_SERIES_SAMPLES)
    out = {"plane": plane, "y": iy, "z": iz, "x_m": float(g.x_m[plane]), "y_m": float(g.y()[iy]),
           "z_m": float(g.z()[iz]), "dt_s": g.dt_s * step, "step": step, "nt": g.nt}  # fmt: skip
    for c in COMPONENTS:
        values = np.asarray(fs.array(c)[::step, plane, iy, iz], dtype=float)
        out[c] = [round(v, 5) for v in values.tolist()]
    tmp.write_text(json.dumps(out))


def build_snapshot(store: Path, component: str, plane: int, it: int, sigma: float | None, tmp: Path) -> None:
    """The yz image of ``component`` at time index ``it`` of plane ``plane`` as a PNG into the new file ``tmp``, colour
    scale +- 3 ``sigma`` [m/s] (the run's standard deviation; None: the frame's own)."""
    from matplotlib.figure import Figure  # not pyplot: no global state shared by the server's threads

    from turbgen.store import open_store

    fs = open_store(store)
    g = fs.grid
    frame = np.asarray(fs.array(component)[it, plane], dtype=float)  # (ny, nz)
    lim = 3.0 * (sigma if sigma else float(frame.std()) or 1.0)
    y, z = g.y(), g.z()
    fig = Figure(figsize=(5.2, 4.2), dpi=90)
    ax = fig.subplots()
    mesh = ax.pcolormesh(y, z, frame.T, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="nearest")
    fig.colorbar(mesh, ax=ax, label=f"{component} [m/s]")
    for s in _measurement_points(fs, plane):
        ax.plot(s["y_m"], s["z_m"], "k+", markersize=12, markeredgewidth=2)
    ax.set(xlabel="y [m]", ylabel="z [m]", aspect="equal",
           title=f"{component} at t = {it * g.dt_s:g} s, x = {g.x_m[plane]:g} m")  # fmt: skip
    fig.tight_layout()
    with open(tmp, "wb") as f:
        fig.savefig(f, format="png")


def _measurement_points(fs, plane: int) -> list[dict]:
    """The measurement points of a constrained store on plane ``plane`` (none for other stores), by the stream's
    recorded plane (a replay's sensor turned into the wind's frame sits on its file x's plane, off its turned x)."""
    record = fs.attrs.get("constraints")
    return [s for s in record["streams"] if s.get("y_m") is not None and s["plane"] == plane] if record else []
