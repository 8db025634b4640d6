"""What the store's model predicts for every estimate (``prediction.Theory``), from the model's declared
``validator_theory`` (``kaimal_expectation``: Guo et al. 2023, Eq. 11, 12, 18, 25; ``mann_expectation``: Eq. 8, 13, 24).
"""

from __future__ import annotations

from turbgen.spec.models import declaration, resolve
from turbgen.validation.prediction import SamplingDesign, Theory


def theory_for(fs, design: SamplingDesign) -> Theory:
    """The predictions of the store ``fs``'s model for the sampling ``design`` (its ``validator_theory``,
    turbgen.spec.models); ParameterError for a model that is not declared."""
    return resolve(declaration(fs.model, "store model").validator_theory, "validation")(fs.attrs, design)
