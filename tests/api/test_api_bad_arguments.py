"""API arguments that used to raise builtin errors (issue 37 §2): each is a ParameterError naming the argument."""

from __future__ import annotations

import pytest

import turbgen
from turbgen.errors import ParameterError
from turbgen.theory.params import MannParams

GRID = {"nt": 16, "ny": 4, "nz": 4}


@pytest.mark.parametrize("planes", [[[0], [50]], "abc", "0,50", [0, None], [0, "50"], [True, 50]],
                         ids=["nested", "text", "csv-text", "none-inside", "text-inside", "bool-inside"])
def test_planes_that_are_not_numbers_are_refused(planes):
    with pytest.raises(ParameterError, match=r"`planes` = .* must be a number or a sequence of numbers x \[m\]"):
        turbgen.mann(**GRID, planes=planes)


def test_gates_that_are_not_numbers_are_refused():
    with pytest.raises(ParameterError, match=r"`gates` = \[\[50\]\]"):
        turbgen.mann(**GRID, gates=[[50]])


@pytest.mark.parametrize("item", [5, None, 1.5, {"x": 1}])
def test_a_constraint_that_is_neither_a_path_nor_loaded_data_is_refused(item):
    with pytest.raises(ParameterError, match=r"constrain item .* is neither a constraint file's path"):
        turbgen.mann(**GRID, planes=[0, 50], constrain=[item])


@pytest.mark.parametrize("k1, match", [([], "is empty"), (["a"], "must be finite numbers"),
                                        ([[1.0], [1.0, 2.0]], "must be finite numbers")])  # fmt: skip
def test_theory_refuses_wavenumbers_that_are_not_numbers(k1, match):
    p = MannParams(ae=0.3, length_scale_m=30.0, gamma=3.1)
    with pytest.raises(ParameterError, match=match):
        turbgen.theory.one_point_spectra(k1, p)
    with pytest.raises(ParameterError, match=match):
        turbgen.theory.cross_spectrum(k1, p, 0, 0)
