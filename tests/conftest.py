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


@pytest.fixture(autouse=True)
def _no_kept_validator_theory():
    """Every test starts without predictions kept by an earlier one (turbgen.validate.theory_cache): a test that
    monkeypatches the validator's internals must compute its theory afresh."""
    import sys

    kept = sys.modules.get("turbgen.validate.theory_cache")
    if kept is not None:
        kept.clear()
    yield
