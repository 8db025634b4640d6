"""Field stores (zarr v3): layout in :mod:`turbgen.store.layout`, safe writing, validated reading.

    from turbgen.store import create_store, open_store, StoreWriter, FieldStore, physical_time_view"""

from turbgen.store.reader import FieldStore, open_store, physical_time_view
from turbgen.store.writer import StoreWriter, create_store

__all__ = ["FieldStore", "StoreWriter", "create_store", "open_store", "physical_time_view"]
