"""The turbgen field store layout (zarr v3): the one place that defines it (docs/store.md shows it).

One zarr v3 group holds one field::

    <store>/zarr.json          group metadata: the attributes below + consolidated metadata
    <store>/u, v, w            float32 (nt, nx, ny, nz), dimension_names DIMS, chunks (chunk_t, 1, ny, nz),
                               uncompressed, fill value NaN, every chunk written (a missing one: a partial copy)
    <store>/t, x, y, z         float64 1-D coordinates, dimension_names (name,), attrs units/long_name

Group attributes (``turbgen/schemas/field.schema.json``): turbgen_version, created_utc, layout_version,
fft_backend, model, parameters, units, seed, U_m_s, hub_height_m, frame = "convected" (plane x at physical time T is
the stored sample t = T + x/U), frame_note, grid, rms_m_s, and last the completeness marker turbgen_complete."""

from __future__ import annotations

import functools
import importlib.resources
import json
import math
import warnings

import jsonschema

from turbgen.grid import Grid
from turbgen.spec.models import model_names


def silence_consolidated_metadata_warning() -> None:
    """Ignore zarr's warning that consolidated metadata is not part of the v3 specification (used knowingly) by a
    process-wide filter for that message only: ``warnings.catch_warnings()`` is not thread-safe."""
    warnings.filterwarnings("ignore", message="Consolidated metadata is currently not part", category=UserWarning)

LAYOUT_VERSION = 1

COMPONENTS = ("u", "v", "w")
DIMS = ("t", "x", "y", "z")
MODELS = model_names()
DTYPE = "float32"
COORD_DTYPE = "float64"

COMPONENT_ATTRS = {
    "u": {"units": "m s-1", "long_name": "longitudinal velocity fluctuation (along the mean wind, downwind)"},
    "v": {"units": "m s-1", "long_name": "lateral velocity fluctuation (along +y)"},
    "w": {"units": "m s-1", "long_name": "vertical velocity fluctuation (along +z, up)"},
}
COORD_ATTRS = {
    "t": {"units": "s", "long_name": "eddy time (convected frame; physical time at plane x is t - x/U)"},
    "x": {"units": "m", "long_name": "upstream distance of the yz-plane from the rotor (rotor = 0)"},
    "y": {"units": "m", "long_name": "lateral position, +y to the left looking downwind, hub = 0"},
    "z": {"units": "m", "long_name": "vertical position relative to hub height, up"},
}

FRAME = "convected"
FRAME_NOTE = ("all planes share one eddy-time axis; the field at plane x and physical time T "
              "is the stored sample at t = T + x/U")

# Attributes the caller of create_store supplies / the writer adds / the marker.
CALLER_ATTRS = ("model", "parameters", "units", "seed", "U_m_s", "hub_height_m")
WRITER_ATTRS = ("turbgen_version", "created_utc", "layout_version", "frame", "frame_note", "grid")
FFT_ATTR = "fft_backend"  # also set by the writer (optional: older stores lack it)
RMS_ATTR = "rms_m_s"  # also set by the writer, with the marker (optional: older stores lack it)
MARKER = "turbgen_complete"

DEFAULT_CHUNK_T_MAX = 1024


def compressor() -> None:
    """Compressor of u, v, w: none; float32 turbulence has random low mantissa bits (benchmarks/README.md)."""
    return None


def default_chunk_t(nt: int) -> int:
    """Default time-chunk length: min(nt, DEFAULT_CHUNK_T_MAX = 1024) samples (16 MiB per chunk at 64 x 64)."""
    return min(nt, DEFAULT_CHUNK_T_MAX)


def chunk_shape(grid: Grid, chunk_t: int) -> tuple[int, int, int, int]:
    """Chunk shape (chunk_t, 1, ny, nz) of u, v, w: one plane, ``chunk_t`` samples, the whole yz-plane."""
    return (chunk_t, 1, grid.ny, grid.nz)


def n_chunks(grid: Grid, chunk_t: int) -> int:
    """Number of chunk files ceil(nt / chunk_t) nx of one component array (all are always written)."""
    return math.ceil(grid.nt / chunk_t) * grid.nx


def grid_to_attrs(grid: Grid) -> dict:
    """The ``grid`` group attribute {nt, dt_s [s], x_m (list) [m], ny, nz, dy_m [m], dz_m [m]}."""
    return {"nt": grid.nt, "dt_s": grid.dt_s, "x_m": list(grid.x_m), "ny": grid.ny, "nz": grid.nz, "dy_m": grid.dy_m,
            "dz_m": grid.dz_m}


def grid_from_attrs(d: dict) -> Grid:
    """Inverse of :func:`grid_to_attrs`; KeyError for a missing key, ParameterError for an invalid value."""
    return Grid(nt=d["nt"], dt_s=d["dt_s"], x_m=tuple(d["x_m"]), ny=d["ny"], nz=d["nz"], dy_m=d["dy_m"], dz_m=d["dz_m"])


def coordinates(grid: Grid) -> dict:
    """Coordinates in ``DIMS`` order: t (nt,) [s], x (nx,), y (ny,), z (nz,) [m, z relative to hub height]."""
    return {"t": grid.t(), "x": grid.x(), "y": grid.y(), "z": grid.z()}


@functools.lru_cache(maxsize=1)
def _validator():
    text = importlib.resources.files("turbgen").joinpath("schemas/field.schema.json").read_text()
    return jsonschema.Draft202012Validator(json.loads(text))


def validate_attrs(attrs: dict, *, where: str, error: type[Exception]) -> None:
    """Check group attributes against ``schemas/field.schema.json``; raise ``error`` (one line) if invalid."""
    err = jsonschema.exceptions.best_match(_validator().iter_errors(attrs))
    if err is None and attrs["model"] not in MODELS:  # the schema takes a string: the models are declared in spec
        raise error(f"{where}: attribute model: {attrs['model']!r} is not one of {', '.join(MODELS)}")
    if err is not None:
        at = "/".join(str(p) for p in err.absolute_path) or "(top level)"
        msg = " ".join(err.message.split())
        if len(msg) > 160:
            msg = msg[:157] + "..."
        raise error(f"{where}: attribute {at}: {msg}")
