"""The run a store describes, decoded from its attributes: the one place the validator reads them.

turbgen.runs writes the model parameters into the store's ``parameters`` attribute; everything the
validator needs of them (the Mann tensor parameters and box, the Kaimal spectra and coherence
models) is decoded here, and nowhere else in turbgen.validate.
"""

from __future__ import annotations

from dataclasses import dataclass

from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.theory.params import KaimalParams, MannParams


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
    """

    params: KaimalParams
    long_model: str
    long_components: str
    vw_coherent: bool
    rescale: bool
    a_x: float | None = None
    b_x: float | None = None


def mann_params_from_attrs(p: dict) -> MannParams:
    """MannParams from the store's ``parameters`` attribute (written by turbgen.runs.mann).

    Raises
    ------
    ParameterError
        If the attribute lacks a Mann parameter (not a turbgen Mann store).
    """
    try:
        return MannParams(ae=p["ae"], length_scale_m=p["length_scale_m"], gamma=p["gamma"], lifetime=p["lifetime"],
                          factor1=p["factor1"], factor2=p["factor2"], evo_time_s=p["evo_time_s"])
    except (KeyError, TypeError) as exc:
        raise ParameterError(f"store parameters lack the Mann model ({exc}); not a turbgen Mann store") from None


def mann_box_from_attrs(p: dict, grid: Grid) -> MannBox:
    """The synthesis box: pad_yz times the grid in y and z (turbgen.runs.mann.MannRun.box).

    Raises
    ------
    ParameterError
        If the attribute lacks ``pad_yz``.
    """
    try:
        pad = int(p["pad_yz"])
        return MannBox(pad * grid.ny, pad * grid.nz)
    except (KeyError, TypeError, ValueError) as exc:
        raise ParameterError(f"store parameters lack the Mann box size ({exc})") from None


def kaimal_model_from_attrs(p: dict) -> KaimalModel:
    """The Kaimal model from the store's ``parameters`` attribute (written by turbgen.runs.kaimal).

    Raises
    ------
    ParameterError
        If the attribute lacks a Kaimal parameter (not a turbgen Kaimal store).
    """
    try:
        kp = KaimalParams(tuple(p["sigma_m_s"]), tuple(p["length_scales_m"]), p["a_yz"], p["lc_m"])
        long_model = p["long_model"]
        a_x, b_x = (p["a_x"], p["b_x"]) if long_model == "exp" else (None, None)
        return KaimalModel(kp, long_model, p["long_components"], p.get("vw_coherence", "white") == "exp",
                           bool(p.get("rescale", False)), a_x, b_x)
    except (KeyError, TypeError) as exc:
        raise ParameterError(f"store parameters lack the Kaimal model ({exc}); not a turbgen Kaimal store") from None
