"""The Python API of turbgen: the commands' runs and products as functions (application layer, over turbgen.runs).

fields    mann, kaimal (fields as xarray Datasets, in memory or in a store), open_store
products  validate, export, lidar (on a store)
keywords  the keywords of mann / kaimal as run-mapping keys (the commands' option names and the run schemas' keys)
"""

from turbgen.api.fields import kaimal, mann, open_store
from turbgen.api.products import export, lidar, validate

__all__ = ["export", "kaimal", "lidar", "mann", "open_store", "validate"]
