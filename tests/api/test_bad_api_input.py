"""Bad values given to the Python API: a typed ParameterError naming the value, before anything is made or written
(issue 37: U=True ran at 1 m/s, memory=-5 said "raise memory", validate(None) said "made in memory",
export(out=None) said "'' is empty")."""

from __future__ import annotations

import numpy as np
import pytest

import turbgen
from turbgen.errors import ParameterError

SMALL = {"nt": 16, "ny": 4, "nz": 4, "planes": [0, 50]}


@pytest.mark.parametrize("keyword, value, text", [
    ("U", True, "U (mean wind speed, m/s) = True is a bool, not a number"),
    ("ae", False, "= False is a bool, not a number"),
    ("nt", True, "nt = True is a bool, not an integer"),
    ("seed", np.True_, "seed = np.True_ is a bool, not an integer"),
])  # fmt: skip
@pytest.mark.parametrize("model", ["mann", "kaimal"])
def test_a_bool_is_not_a_number(tmp_path, model, keyword, value, text):
    if model == "kaimal" and keyword == "ae":
        keyword, text = "ayz", "= False is a bool, not a number"
    with pytest.raises(ParameterError, match="bool, not") as err:
        getattr(turbgen, model)(**{**SMALL, keyword: value}, out=tmp_path / "f.zarr")
    assert text in str(err.value) and "\n" not in str(err.value)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("memory", [-5, 0, True])
def test_a_memory_budget_below_one_byte_is_a_mistake_not_too_little_memory(tmp_path, memory):
    with pytest.raises(ParameterError, match=r"`memory` \(bytes\) = ") as err:
        turbgen.mann(**SMALL, ae=0.3, memory=memory, out=tmp_path / "f.zarr")
    assert "raise" not in str(err.value)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("call", ["validate", "lidar", "export"])
def test_no_store_is_named_as_none(call):
    args = (None, "bts", "x.bts") if call == "export" else (None,)
    with pytest.raises(ParameterError, match="store = None; give a store path") as err:
        getattr(turbgen, call)(*args)
    assert "memory" not in str(err.value)


def test_export_without_out_names_none(tmp_path):
    store = tmp_path / "k.zarr"
    turbgen.kaimal(**SMALL, out=store)
    with pytest.raises(ParameterError, match=r"^`out` = None; give a file or directory name$"):
        turbgen.export(store, "bts", None)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["k.zarr"]
