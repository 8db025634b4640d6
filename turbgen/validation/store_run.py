"""The run a store describes, decoded from its attributes: the one place the validator reads them.

The store's attributes are decoded by the run's own spec (turbgen.spec: ``MannRun.from_attrs``,
``KaimalRun.from_attrs``, which also read older stores); here is the one place the validator asks
for what it needs of them (the Mann tensor parameters and box, the Kaimal spectra and coherence models).
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
    """The Kaimal / IEC model of a store.

    Attributes
    ----------
    params : KaimalParams
        sigma_i [m/s], length scales [m], yz coherence decrement a_yz [-] and scale lc [m].
    long_model : str
        Longitudinal coherence model between planes (a key of theory.coherence_models.LONGITUDINAL_MODELS).
    long_components : str
        Components the longitudinal model was applied to (the others are independent between planes).
    vw_coherent : bool
        True if v and w have the exponential yz coherence of u, False if they are white in y, z.
    rescale : bool
        True if each spectrum was rescaled to the nominal sigma_i.
    a_x, b_x : float or None
        Coefficients of the exponential longitudinal coherence (``long_model == "exp"``), else None.
    spectrum : LineSpectrum or None
        The user spectra the store was made with (band means on its lines), or None for the Kaimal spectra.
    coherence : LineCoherence or None
        The user yz coherence the store was made with, or None for the IEC exponential.
    """

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
    """MannParams of a Mann store (its run, turbgen.spec.mann.MannRun.from_attrs).

    Raises
    ------
    ParameterError
        If the attributes lack a Mann parameter (not a turbgen Mann store).
    """
    return MannRun.from_attrs(attrs).params


def mann_box_from_attrs(attrs: dict, grid: Grid) -> MannBox:
    """The synthesis box of a Mann store: pad_yz times the grid in y and z.

    Raises
    ------
    ParameterError
        If the attributes lack a Mann parameter.
    """
    pad = MannRun.from_attrs(attrs).pad_yz
    return MannBox(pad * grid.ny, pad * grid.nz)


def kaimal_model_from_attrs(attrs: dict) -> KaimalModel:
    """The Kaimal model of a Kaimal store (its run, turbgen.spec.kaimal.KaimalRun.from_attrs).

    Raises
    ------
    ParameterError
        If the attributes lack a Kaimal parameter (not a turbgen Kaimal store).
    """
    run = KaimalRun.from_attrs(attrs)
    return KaimalModel(run.kaimal, run.long_model, run.long_components, run.vw_coherence == "exp", run.rescale,
                       run.a_x, run.b_x, run.spectrum, run.coherence)
