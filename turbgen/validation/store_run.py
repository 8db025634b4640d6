"""The run a store describes, decoded from its attributes by the run's own spec (``MannRun.from_attrs``,
``KaimalRun.from_attrs``): the one place the validator reads them."""

from __future__ import annotations

from dataclasses import dataclass

from turbgen.grid import Grid
from turbgen.spec.kaimal import KaimalRun
from turbgen.spec.mann import MannRun
from turbgen.theory.params import MannParams


@dataclass(frozen=True)
class MannBox:
    """The generator's periodic box in y, z: nyp x nzp points spaced dy, dz (the grid is its corner)."""

    nyp: int
    nzp: int


def mann_params_from_attrs(attrs: dict) -> MannParams:
    """MannParams of a Mann store; ParameterError if the attributes lack one (not a turbgen Mann store)."""
    return MannRun.from_attrs(attrs).params


def mann_box_from_attrs(attrs: dict, grid: Grid) -> MannBox:
    """The synthesis box of a Mann store, pad_yz times the grid in y and z; ParameterError as above."""
    pad = MannRun.from_attrs(attrs).pad_yz
    return MannBox(pad * grid.ny, pad * grid.nz)


def kaimal_model_from_attrs(attrs: dict) -> KaimalRun:
    """The Kaimal run of a Kaimal store (its model: ``kaimal`` parameters, longitudinal model, user spectrum and
    coherence tables); ParameterError if the attributes lack a Kaimal parameter."""
    return KaimalRun.from_attrs(attrs)
