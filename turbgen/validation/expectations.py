"""Theory side of the validation: what the store's model predicts for every estimate, on the store's grid.

Both generators synthesise a periodic record of nt samples, i.e. spectral *lines* at f_j = j / (nt dt)
(turbgen.theory.lattice); the predictions are line (cross-)variances (``prediction.Theory``) for the
points and segments the estimates used (``prediction.SamplingDesign``):

* ``kaimal_expectation``: Kaimal / IEC spectra and coherences (Guo et al. 2023, Eq. 11, 12, 18, 25);
* ``mann_expectation``: the Mann tensor summed over the lattice of the generator's box
  (Guo et al. 2023, Eq. 8, 13, 24), with the lattice sums in ``mann_lattice``;
* ``welch_kernel``: the exact expected Welch estimate of a line process;
* ``pair_sums``: correlation sums rho_bar over the averaged point sets (tolerances in ``verdict``);
* ``store_run``: the run parameters decoded from the store's attributes.
"""

from __future__ import annotations

from turbgen.spec.models import declaration, resolve
from turbgen.validation.prediction import SamplingDesign, Theory


def theory_for(fs, design: SamplingDesign) -> Theory:
    """The predictions of the store's model.

    Parameters
    ----------
    fs : turbgen.store.FieldStore
        The store (its ``model`` and attributes).
    design : SamplingDesign
        Grid, Welch segments and point sets of the estimates.

    Returns
    -------
    Theory
        Line (cross-)variances [m^2 s^-2] and correlation sums rho_bar [-]: the model's ``validator_theory``
        (turbgen.spec.models).

    Raises
    ------
    ParameterError
        For a model that is not declared.
    """
    return resolve(declaration(fs.model, "store model").validator_theory, "validation")(fs.attrs, design)
