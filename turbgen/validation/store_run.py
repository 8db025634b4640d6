"""The run a store describes, decoded from its attributes by the run's own spec (``MannRun.from_attrs``,
``KaimalRun.from_attrs``): the one place the validator reads them.
"""

from __future__ import annotations

from dataclasses import dataclass

from turbgen.grid import Grid
from turbgen.spec.kaimal import KaimalRun
from turbgen.spec.mann import MannRun
from turbgen.theory.params import KaimalParams, MannParams
from turbgen.theory.user_coherence import LineCoherence
from turbgen.theory.user_spectra import LineSpectrum


@dataclass(frozen=True)
class MannBox:
    """The generator's periodic box in y, z: nyp x nzp points spaced dy, dz (the grid is its corner)."""

    nyp: int
    nzp: int


@dataclass(frozen=True)
class KaimalModel:
    """The Kaimal / IEC model of a store: ``params``, the longitudinal model (a key of
    theory.coherence_models.LONGITUDINAL_MODELS, ``a_x``, ``b_x`` for "exp") and the components it applies to,
    whether v, w have u's yz coherence and the spectra were rescaled, and the user ``spectrum`` and ``coherence``
    (None: Kaimal, IEC exponential)."""

    params: KaimalParams
    long_model: str
    long_components: str
    vw_coherent: bool
    rescale: bool
    a_x: float | None = None
    b_x: float | None = None
    spectrum: LineSpectrum | None = None
    coherence: LineCoherence | None = None


def mann_params_from_attrs(attrs: dict) -> MannParams:
    """MannParams of a Mann store; ParameterError if the attributes lack one (not a turbgen Mann store)."""
    return MannRun.from_attrs(attrs).params


def mann_box_from_attrs(attrs: dict, grid: Grid) -> MannBox:
    """The synthesis box of a Mann store, pad_yz times the grid in y and z; ParameterError as above."""
    pad = MannRun.from_attrs(attrs).pad_yz
    return MannBox(pad * grid.ny, pad * grid.nz)


def kaimal_model_from_attrs(attrs: dict) -> KaimalModel:
    """The Kaimal model of a Kaimal store; ParameterError if the attributes lack a Kaimal parameter."""
    run = KaimalRun.from_attrs(attrs)
    return KaimalModel(run.kaimal, run.long_model, run.long_components, run.vw_coherence == "exp", run.rescale,
                       run.a_x, run.b_x, run.spectrum, run.coherence)
