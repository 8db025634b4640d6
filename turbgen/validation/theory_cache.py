"""The model's predictions for a store, kept in this process for the next store that differs only in seed.

The key is every attribute but seed, creation time and measured rms."""

from __future__ import annotations

import json
import threading
from collections import OrderedDict

ENTRIES = 4  # a theory with its expectations is a few MB
_SEED_ONLY = ("seed", "created_utc", "rms_m_s")  # rms_m_s: what the writer measured of the data
_lock = threading.Lock()
_entries: OrderedDict = OrderedDict()


def theory_key(model: str, attrs: dict, **options) -> str:
    """The cache key (canonical JSON) of a store's predictions: ``model``, ``attrs`` without the seed-only keys (at the
    top level and in ``parameters``) and the estimates' ``options`` (e.g. rotor_radius_m, nperseg)."""
    kept = {k: v for k, v in attrs.items() if k not in _SEED_ONLY}
    if isinstance(kept.get("parameters"), dict):
        kept["parameters"] = {k: v for k, v in kept["parameters"].items() if k not in _SEED_ONLY}
    return json.dumps({"model": model, "attrs": kept, "options": options}, sort_keys=True, default=repr)


def cached(key: str, compute):
    """(value, hit): ``compute()``'s result for ``key``, computed (outside the lock) unless kept (hit True)."""
    with _lock:
        if key in _entries:
            _entries.move_to_end(key)
            return _entries[key], True
    value = compute()
    with _lock:
        _entries[key] = value
        while len(_entries) > ENTRIES:
            _entries.popitem(last=False)
    return value, False


def clear() -> None:
    """Forget every kept prediction."""
    with _lock:
        _entries.clear()
