"""The Python API of turbgen: the commands' runs and products as functions (application layer, over turbgen.runs).

fields    mann, kaimal (fields as xarray Datasets, in memory or in a store), open_store
products  validate, export, lidar, info (on a store or a field in memory)
generator MannGenerator, KaimalGenerator (one parameter set and grid, a field per seed)

Their keywords become a run as the commands' options do: turbgen.spec.run_mapping."""

from turbgen.api.fields import kaimal, mann, open_store
from turbgen.api.generator import KaimalGenerator, MannGenerator
from turbgen.api.products import export, info, lidar, validate

__all__ = ["KaimalGenerator", "MannGenerator", "export", "info", "kaimal", "lidar", "mann", "open_store", "validate"]
