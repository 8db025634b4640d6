"""turbgen: 4D stochastic wind-turbulence fields u(t, x, y, z).

Mann (1994) space-time generator (Guo et al. 2022) and Kaimal/IEC generator with
direct-product longitudinal coherence (evoTurb style), zarr stores, validation against
theory, and exports for OpenFAST / HAWC2 / lidar simulators.

The Python API (the same runs, the same bits as the ``turbgen`` commands; turbgen.api):

    mann, kaimal    a field as an xarray.Dataset (in memory, or written to a store with ``out``)
    MannGenerator, KaimalGenerator
                    one parameter set and grid, a field per seed (the seed-free part made once)
    MannParams, KaimalParams, Grid
                    the frozen, validated parameter sets and grid (units in the field names)
    open_store      a store as a lazy xarray.Dataset, after checking it
    validate        the store against its model (a report)
    export          bts, wnd, evo, hawc2, mt4d, hdf5
    lidar           a virtual lidar on a store
    info            what ``turbgen info`` shows of a store, a field or an exported file
    fit_mann, fit_kaimal
                    the model's parameters fitted to measured data or a field, with 95 % intervals
    point_series    measured point series made in memory (what a constraint file holds): to fit, to condition on
    theory          the pure theory functions: spectra, coherences, lidar preview
    errors          ParameterError, StoreError (both TurbgenError)

Names are imported on first use, so ``import turbgen`` (and every command) stays cheap."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from turbgen.version import __version__

# the public functions and typed objects: name -> module; what is made from a field (turbgen.api.products) comes of
# turbgen.validation, turbgen.exporters and turbgen.virtual_lidar
_OBJECTS = {"mann": "turbgen.api.fields", "kaimal": "turbgen.api.fields", "open_store": "turbgen.api.fields",
            "validate": "turbgen.api.products", "export": "turbgen.api.products", "lidar": "turbgen.api.products",
            "info": "turbgen.api.products", "MannParams": "turbgen.theory.params",
            "KaimalParams": "turbgen.theory.params", "Grid": "turbgen.grid", "MannGenerator": "turbgen.api.generator",
            "KaimalGenerator": "turbgen.api.generator", "fit_mann": "turbgen.api.fit", "fit_kaimal": "turbgen.api.fit",
            "point_series": "turbgen.spec.constraints"}
_MODULES = ("theory", "errors", "api")
__all__ = ["__version__", *_OBJECTS, "theory", "errors"]

if TYPE_CHECKING:
    from turbgen import errors, theory
    from turbgen.api.generator import KaimalGenerator, MannGenerator
    from turbgen.api.fields import kaimal, mann, open_store
    from turbgen.api.fit import fit_kaimal, fit_mann
    from turbgen.api.products import export, info, lidar, validate
    from turbgen.grid import Grid
    from turbgen.spec.constraints import point_series
    from turbgen.theory.params import KaimalParams, MannParams


def __getattr__(name: str):
    if name in _OBJECTS:
        return getattr(importlib.import_module(_OBJECTS[name]), name)
    if name in _MODULES:
        return importlib.import_module(f"turbgen.{name}")
    raise AttributeError(f"module 'turbgen' has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *__all__})


