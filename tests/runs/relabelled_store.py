"""A store's field written again under its attributes without one run parameter (the validator's FAIL cases)."""

from turbgen.store import create_store, open_store
from turbgen.store.layout import CALLER_ATTRS


def without_parameter(store, key: str, out):
    """Copy the field of ``store`` to a new store ``out`` whose ``parameters`` lack ``key``; returns ``out``."""
    fs = open_store(store)
    attrs = {k: fs.attrs[k] for k in CALLER_ATTRS}
    attrs["parameters"] = {k: v for k, v in attrs["parameters"].items() if k != key}
    with create_store(out, fs.grid, attrs) as w:
        for c in "uvw":
            for ix in range(fs.grid.nx):
                w.write(c, ix, fs.read_plane(c, ix))
    return out
