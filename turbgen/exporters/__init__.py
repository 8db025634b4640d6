"""Exports of a turbgen store to the files aeroelastic and lidar simulators read (docs/export.md).

Formats: ``bts`` (TurbSim, WindType 3), ``wnd`` (Bladed-style .wnd + .sum, WindType 4), ``evo`` (lidar-simulator
4D set), ``hawc2`` (three float32 .bin, WindType 5), ``mt4d`` (4D Mann generator layout), ``hdf5`` (whole field)."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from turbgen.exporters.bts import export_bts, read_bts
from turbgen.exporters.evo import export_evo, read_evo
from turbgen.exporters.hawc2 import export_hawc2, read_hawc2
from turbgen.exporters.hdf5 import export_hdf5, read_hdf5
from turbgen.exporters.mt4d import export_mt4d, read_mt4d
from turbgen.exporters.request import ExportRequest, ExportResult
from turbgen.exporters.wnd import export_wnd, read_wnd
from turbgen.exporters.wnd_summary import read_sum
from turbgen.errors import ParameterError, check_choice
from turbgen.resources import require_disk
from turbgen.store import FieldStore, open_store

WHOLE_FIELD = ("mt4d", "hdf5")  # every plane, stored fluctuations
EXPORTERS = {"bts": export_bts, "wnd": export_wnd, "evo": export_evo, "hawc2": export_hawc2,
             "mt4d": export_mt4d, "hdf5": export_hdf5}

__all__ = ["EXPORTERS", "ExportRequest", "ExportResult", "export_store", "read_bts", "read_evo", "read_hawc2",
           "read_hdf5", "read_mt4d", "read_sum", "read_wnd"]


def export_store(store, fmt: str, out, request: ExportRequest | None = None) -> ExportResult:
    """Export ``store`` (a path or FieldStore) as ``fmt`` to ``out`` (ROOT for wnd, evo, hawc2): the export engine;
    ParameterError for an unknown format, unused options, a bad or existing ``out``, too little disk; StoreError for a
    missing or incomplete store."""
    check_choice("format", fmt, tuple(EXPORTERS))
    if isinstance(out, str) and out.endswith(("/", os.sep)):
        raise ParameterError(f"`out` = {out!r} names a directory; give the file (or ROOT) to write")
    request = request or ExportRequest()
    _check_applicable(fmt, request)
    if not isinstance(store, FieldStore):
        store = open_store(store)
    if store.path is not None and Path(store.path).resolve() in Path(out).resolve().parents:
        raise ParameterError(f"`out` = {str(out)!r} is inside the store {str(store.path)!r}; write the export beside it")
    require_disk(out, export_bytes(fmt, store.grid), f"the {fmt} export of {Path(store.label).name}",
                 "free space there or choose another `out`")
    result = EXPORTERS[fmt](store, out, request)
    return replace(result, notes=(*request.notes, *result.notes)) if request.notes else result


# bytes per stored value and whether every plane is written, per format
_SIZE = {"bts": (2, False), "wnd": (2, False), "hawc2": (4, False), "evo": (2, True), "mt4d": (4, True),
         "hdf5": (4, True)}


def export_bytes(fmt: str, grid) -> int:
    """Upper bound [bytes] of an export of a store with ``grid`` in format ``fmt``."""
    itemsize, all_planes = _SIZE[fmt]
    values = 3 * grid.nt * grid.ny * grid.nz * (grid.nx if all_planes else 1)
    extra = 3 * grid.nt * grid.ny * grid.nz * 2 if fmt == "evo" else 0  # evo also writes the rotor .wnd
    return values * itemsize + extra + (1 << 20)  # + headers, HDF5 metadata


def _check_applicable(fmt: str, request: ExportRequest) -> None:
    """Refuse options that the format would silently ignore."""
    given = []
    if request.tower and fmt != "bts":
        given.append("`tower` (bts only)")
    if request.runner_files and fmt not in ("bts", "wnd", "evo", "hawc2"):
        given.append("`runner_files` (bts, wnd, evo, hawc2 only)")
    if not request.periodic and fmt not in ("bts", "wnd", "evo"):
        given.append("`no_periodic` (bts, wnd, evo only; HAWC boxes are always periodic)")
    if fmt in WHOLE_FIELD:
        if request.plane is not None:
            given.append("`plane`")
        if (request.hub_height_m is not None or request.drop_below_ground or request.shear_exponent is not None
                or request.mean_wind is not None):
            given.append("`hub_height`/`shear_exponent`/`drop_below_ground` or a mean wind (profile, veer, history): "
                         "no mean profile is added")
    if given:
        raise ParameterError(f"`format` {fmt} does not use {'; '.join(given)}")
