"""Test configuration: hypothesis runs derandomized (the same examples on every run and machine)."""

from hypothesis import settings

settings.register_profile("turbgen", derandomize=True, deadline=None)
settings.load_profile("turbgen")
