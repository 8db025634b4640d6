"""The model's predictions for a store, kept for the next store that differs only in seed.

The theory and the expected Welch estimates depend on the store's model, parameters and grid and on the
options of the estimates (rotor radius, segment length), never on the seed or the data: a sweep validating
20 seeds of one configuration computes them once (for a Mann store they cost more than the estimates, which
they also slow down when run beside them). The key is every attribute of the store but
its seed, creation time and the data's measured rms (any other difference, e.g. another turbgen version, makes a new entry), and
the entries are kept in this process only (sweep workers, the service, library loops), a few at a time.
"""

from __future__ import annotations

import json
import threading
from collections import OrderedDict

ENTRIES = 4  # a theory with its expectations is a few MB
_SEED_ONLY = ("seed", "created_utc", "rms_m_s")  # rms_m_s: what the writer measured of the data
_lock = threading.Lock()
_entries: OrderedDict = OrderedDict()


def theory_key(model: str, attrs: dict, **options) -> str:
    """The cache key of a store's predictions: its model, attributes without the seed, and ``options``.

    Parameters
    ----------
    model : str
        The store's model.
    attrs : dict
        The store's attributes (``seed`` and ``created_utc`` are left out, at the top level and in
        ``parameters``).
    **options
        The options of the estimates (e.g. rotor_radius_m, nperseg).

    Returns
    -------
    str
        A canonical JSON text.
    """
    kept = {k: v for k, v in attrs.items() if k not in _SEED_ONLY}
    if isinstance(kept.get("parameters"), dict):
        kept["parameters"] = {k: v for k, v in kept["parameters"].items() if k not in _SEED_ONLY}
    return json.dumps({"model": model, "attrs": kept, "options": options}, sort_keys=True, default=repr)


def cached(key: str, compute):
    """``compute()``'s result for ``key``, computed only if this process has not kept it.

    Parameters
    ----------
    key : str
        From :func:`theory_key`.
    compute : callable
        Returns the value; called outside the lock (two threads missing the same key both compute it).

    Returns
    -------
    tuple
        (value, hit): hit is True when the value was kept from an earlier call.
    """
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
