"""Theory side of the validation: what the store's model predicts for every estimate, on the store's grid.

Both generators synthesise a periodic record of nt samples, i.e. spectral *lines* at f_j = j / (nt dt)
(turbgen.theory.lattice); the predictions are line (cross-)variances (``prediction.Theory``) for the points and
segments the estimates used (``prediction.SamplingDesign``), from the model's declared ``validator_theory``
(``kaimal_expectation``: Guo et al. 2023, Eq. 11, 12, 18, 25; ``mann_expectation``: Eq. 8, 13, 24).
"""

from __future__ import annotations

from turbgen.spec.models import declaration, resolve
from turbgen.validation.prediction import SamplingDesign, Theory


def theory_for(fs, design: SamplingDesign) -> Theory:
    """The predictions of the store ``fs``'s model for the sampling ``design`` (its ``validator_theory``,
    turbgen.spec.models); ParameterError for a model that is not declared.
    """
    return resolve(declaration(fs.model, "store model").validator_theory, "validation")(fs.attrs, design)
