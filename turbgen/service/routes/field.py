"""Routes of the field itself (turbgen.service.field_view): a point's u, v, w time series and a yz snapshot image,
each made on first request and cached (starting one needs the token, as every derived product)."""

from __future__ import annotations

import json
from functools import partial
from pathlib import Path

from fastapi import APIRouter, Depends, Request
from fastapi.responses import FileResponse

from turbgen.errors import ParameterError
from turbgen.service.derived import cached_product
from turbgen.service.field_view import COMPONENTS, build_series, build_snapshot, check_index
from turbgen.service.state import ServiceState, complete_store, get_state

router = APIRouter()


def _grid(state: ServiceState, rid: str) -> dict:
    return state.catalog.request(rid)["run"]["grid"]


@router.get("/runs/{rid}/series")
def series(rid: str, request: Request, plane: int = 0, y: int = 0, z: int = 0,
           store: Path = Depends(complete_store), state: ServiceState = Depends(get_state)):  # fmt: skip
    """u, v, w time series [m/s] at grid point (``y``, ``z``) (indices) of plane ``plane`` (index), with the point's
    coordinates ``x_m``, ``y_m``, ``z_m`` [m] and the sample spacing ``dt_s`` [s]."""
    g = _grid(state, rid)
    check_index("plane", plane, len(g["x_m"]))
    check_index("y", y, g["ny"])
    check_index("z", z, g["nz"])
    final = state.catalog.run_dir(rid) / "view" / f"series-x{plane}-y{y}-z{z}.json"
    cached_product(state, request, rid, final, Path.is_file, partial(build_series, store, plane, y, z))
    return json.loads(final.read_text())


@router.get("/runs/{rid}/snapshot")
def snapshot(rid: str, request: Request, plane: int = 0, t: int = 0, component: str = "u",
             store: Path = Depends(complete_store), state: ServiceState = Depends(get_state)):  # fmt: skip
    """A PNG image of ``component`` over the yz plane ``plane`` (index) at time index ``t`` (colour scale +- 3 sigma
    of the run; a constrained field's measurement points on that plane marked +)."""
    if component not in COMPONENTS:
        raise ParameterError(f"component = {component!r} is not one of {', '.join(COMPONENTS)}")
    g = _grid(state, rid)
    check_index("plane", plane, len(g["x_m"]))
    check_index("t", t, g["nt"])
    try:
        sigma = json.loads((state.catalog.run_dir(rid) / "summary.json").read_text()).get(f"sigma_{component}")
    except (OSError, ValueError):
        sigma = None
    final = state.catalog.run_dir(rid) / "view" / f"snapshot-{component}-x{plane}-t{t}.png"
    cached_product(state, request, rid, final, Path.is_file, partial(build_snapshot, store, component, plane, t, sigma))
    return FileResponse(final, media_type="image/png")
