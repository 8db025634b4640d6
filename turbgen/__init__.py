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
    theory          the pure theory functions: spectra, coherences, lidar preview
    errors          ParameterError, StoreError (both TurbgenError)

Names are imported on first use, so ``import turbgen`` (and every command) stays cheap.
"""

from __future__ import annotations

import importlib
import inspect
import types
from typing import TYPE_CHECKING

from turbgen.version import __version__

_FIELDS = ("mann", "kaimal", "open_store")
_INFO = ("info",)
# public typed objects and functions of their own modules: name -> module
_OBJECTS = {"MannParams": "turbgen.theory.params", "KaimalParams": "turbgen.theory.params", "Grid": "turbgen.grid",
            "MannGenerator": "turbgen.api.generator", "KaimalGenerator": "turbgen.api.generator",
            "fit_mann": "turbgen.api.fit"}
# API functions named like a subpackage: turbgen.validate(...) calls the function, turbgen.validate.report is the
# subpackage's module (see _Package)
_PRODUCTS = ("validate", "export", "lidar")
_MODULES = ("theory", "errors", "api")
__all__ = ["__version__", *_FIELDS, *_PRODUCTS, *_INFO, *_OBJECTS, "theory", "errors"]

if TYPE_CHECKING:
    from turbgen import errors, theory
    from turbgen.api.generator import KaimalGenerator, MannGenerator
    from turbgen.api.fields import kaimal, mann, open_store
    from turbgen.api.fit import fit_mann
    from turbgen.api.products import export, info, lidar, validate
    from turbgen.grid import Grid
    from turbgen.theory.params import KaimalParams, MannParams


class _Product:
    # ``turbgen.validate`` (``export``, ``lidar``): the API function (turbgen.api.products) and a subpackage share
    # one name, so ``turbgen.validate(store)`` calls the function while attribute reads and writes go to the
    # subpackage (imported on first use): ``import turbgen.validate.report`` and ``turbgen.export.EXPORTERS`` work.

    def __init__(self, name: str):
        object.__setattr__(self, "_name", name)

    def _function(self):
        return getattr(importlib.import_module("turbgen.api.products"), self._name)

    def _package(self):
        return importlib.import_module(f"turbgen.{self._name}")

    def __call__(self, *args, **kwargs):
        return self._function()(*args, **kwargs)

    # help(), inspect.signature() and Sphinx see the function
    __doc__ = property(lambda self: self._function().__doc__)
    __signature__ = property(lambda self: inspect.signature(self._function()))

    def __getattr__(self, attr):
        return getattr(self._package(), attr)

    # vars(turbgen.validate) is the subpackage's namespace, as for a module (tools such as pytest's monkeypatch read
    # and restore attributes through it)
    __dict__ = property(lambda self: vars(self._package()))

    def __setattr__(self, attr, value):
        setattr(self._package(), attr, value)

    def __delattr__(self, attr):
        delattr(self._package(), attr)

    def __repr__(self) -> str:
        return f"<turbgen.{self._name}: function turbgen.api.products.{self._name} and package turbgen.{self._name}>"


class _Package(types.ModuleType):
    """The ``turbgen`` module: importing a subpackage named like an API function keeps the function's name bound to
    its _Product (the import system sets ``turbgen.<name>`` to the subpackage, which this ignores)."""

    def __setattr__(self, name, value):
        if name in _PRODUCTS and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


def __getattr__(name: str):
    if name in _FIELDS:
        return getattr(importlib.import_module("turbgen.api.fields"), name)
    if name in _INFO:
        return getattr(importlib.import_module("turbgen.api.products"), name)
    if name in _OBJECTS:
        return getattr(importlib.import_module(_OBJECTS[name]), name)
    if name in _MODULES:
        return importlib.import_module(f"turbgen.{name}")
    raise AttributeError(f"module 'turbgen' has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *__all__})


validate, export, lidar = (_Product(name) for name in _PRODUCTS)
importlib.import_module(__name__).__class__ = _Package
