"""Test configuration.

- hypothesis runs derandomized (the same examples on every run and machine);
- ``TURBGEN_FAST=1`` in the environment skips the tests marked ``slow`` (long statistical tests);
  CI leaves it unset and runs everything;
- Ctrl-C is handled as in a terminal even when the suite was started with SIGINT ignored (a background job of a
  shell without job control, ``nohup``): the interruption tests send SIGINT and expect turbgen's reaction, which
  turbgen rightly withholds where the user's environment ignores the signal.
"""

import os
import signal

import pytest
from hypothesis import settings

settings.register_profile("turbgen", derandomize=True, deadline=None)
settings.load_profile("turbgen")


def pytest_configure(config):
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:  # inherited: restore Python's default (KeyboardInterrupt)
        signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_collection_modifyitems(config, items):
    if os.environ.get("TURBGEN_FAST", "") not in ("", "0"):
        skip = pytest.mark.skip(reason="slow test skipped because TURBGEN_FAST is set")
        for item in items:
            if "slow" in item.keywords:
                item.add_marker(skip)


_theory_kept_for = None  # the module whose tests share the validator's kept predictions, while its tests run


@pytest.fixture(autouse=True)
def _no_kept_validator_theory(request):
    """Every test starts without predictions kept by an earlier one (turbgen.validation.theory_cache): a test that
    monkeypatches the validator's internals must compute its theory afresh. A module that sets
    ``KEEP_VALIDATOR_THEORY = True`` (it patches nothing of the validator) keeps them from one of its tests to the
    next, as a sweep keeps them between stores that differ only in seed; its first test starts without any."""
    import sys

    global _theory_kept_for
    keep = getattr(request.module, "KEEP_VALIDATOR_THEORY", False)
    kept = sys.modules.get("turbgen.validation.theory_cache")
    if kept is not None and not (keep and _theory_kept_for is request.module):
        kept.clear()
    _theory_kept_for = request.module if keep else None
    yield


@pytest.fixture()
def small_disk(tmp_path):
    """A factory of tiny file systems: ``small_disk("3M")`` mounts a tmpfs of that size (the full-disk tests meet a
    real ENOSPC, and with a writable map of a sparse file, a real SIGBUS); unmounted after the test. Skips, saying
    why, where mounting is impossible (not root, no tmpfs)."""
    import subprocess

    mounted = []

    def make(size: str):
        where = tmp_path / f"disk{len(mounted)}"
        where.mkdir()
        try:
            done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                                  capture_output=True, text=True)  # fmt: skip
            why = done.stderr.strip() or f"mount exited {done.returncode}"
        except OSError as exc:
            done, why = None, str(exc)
        if done is None or done.returncode != 0:
            pytest.skip(f"cannot mount a {size} tmpfs for a real full disk: {why}")
        mounted.append(where)
        return where

    yield make
    for where in mounted:
        subprocess.run(["umount", "-l", str(where)], capture_output=True)
