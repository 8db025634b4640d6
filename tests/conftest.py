"""Test configuration.

- hypothesis runs derandomized (the same examples on every run and machine);
- ``TURBGEN_FAST=1`` in the environment skips the tests marked ``slow`` (long statistical tests);
  CI leaves it unset and runs everything.
"""

import os

import pytest
from hypothesis import settings

settings.register_profile("turbgen", derandomize=True, deadline=None)
settings.load_profile("turbgen")


def pytest_collection_modifyitems(config, items):
    if os.environ.get("TURBGEN_FAST", "") not in ("", "0"):
        skip = pytest.mark.skip(reason="slow test skipped because TURBGEN_FAST is set")
        for item in items:
            if "slow" in item.keywords:
                item.add_marker(skip)


_theory_kept_for = None  # the module whose tests share the validator's kept predictions, while its tests run


@pytest.fixture(autouse=True)
def _no_kept_validator_theory(request):
    """Every test starts without predictions kept by an earlier one (turbgen.validate.theory_cache): a test that
    monkeypatches the validator's internals must compute its theory afresh. A module that sets
    ``KEEP_VALIDATOR_THEORY = True`` (it patches nothing of the validator) keeps them from one of its tests to the
    next, as a sweep keeps them between stores that differ only in seed; its first test starts without any."""
    import sys

    global _theory_kept_for
    keep = getattr(request.module, "KEEP_VALIDATOR_THEORY", False)
    kept = sys.modules.get("turbgen.validate.theory_cache")
    if kept is not None and not (keep and _theory_kept_for is request.module):
        kept.clear()
    _theory_kept_for = request.module if keep else None
    yield
