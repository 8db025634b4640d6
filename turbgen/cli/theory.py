"""`turbgen theory ...` and `turbgen fit ...`: model spectra, coherences and fits on the command line."""

from __future__ import annotations

import click


@click.group()
def theory():
    """Evaluate model spectra and coherences (Mann, space-time, Kaimal)."""


@click.group()
def fit():
    """Fit Kaimal / exponential-coherence models to the Mann (space-time) model."""
