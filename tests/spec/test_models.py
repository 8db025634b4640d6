"""The model registry (turbgen.spec.models): every declared part resolves in its own layer, and the readers agree."""

import pytest

from turbgen.errors import ParameterError
from turbgen.spec.models import DECLARATIONS, declaration, model_names, resolve

# declaration field -> the layer its reference must lie in (the layers of pyproject.toml's import contract)
LAYERS = {"spec": "spec", "options": "spec", "replaces": "spec", "command": "cli", "runner": "runs",
          "synthesis": "synthesis", "validator_theory": "validation", "preview": "virtual_lidar", "store_preview": "virtual_lidar"}


@pytest.mark.parametrize("d", DECLARATIONS, ids=lambda d: d.name)
def test_every_reference_resolves_in_its_layer(d):
    for field, layer in LAYERS.items():
        reference = getattr(d, field)
        if reference is not None:
            assert resolve(reference, layer) is not None, field
    run_class = resolve(d.spec, "spec")
    runner = resolve(d.runner, "runs")
    assert runner.name == d.name and runner.spec is run_class
    assert run_class.from_mapping({"grid": {"nt": 64, "ny": 4, "nz": 4, "x_m": [0.0]}}).model == d.name
    assert set(resolve(d.options, "spec").values()) <= set(__import__("turbgen.spec.config", fromlist=["x"])
                                                            .load_schema(d.schema)["properties"])


def test_the_readers_list_the_declared_models():
    from turbgen.cli import COMMANDS
    from turbgen.virtual_lidar.preview import MODELS as PREVIEW
    from turbgen.runs.models import MODELS as RUNNERS
    from turbgen.store.layout import MODELS as STORE

    names = model_names()
    assert names == ("mann", "kaimal") and STORE == names and tuple(RUNNERS) == names
    assert PREVIEW == tuple(d.name for d in DECLARATIONS if d.preview) and set(names) <= set(COMMANDS)


def test_a_reference_outside_its_layer_and_an_unknown_model_are_refused():
    with pytest.raises(ValueError, match="is not a turbgen.validation attribute"):
        resolve(declaration("kaimal").runner, "validation")
    with pytest.raises(ParameterError, match="store model = 'karman' is not one of mann, kaimal"):
        declaration("karman", "store model")


def test_a_store_of_an_undeclared_model_is_refused_in_one_line():
    from turbgen.store.layout import validate_attrs

    from turbgen.spec.kaimal import KaimalRun
    from turbgen.store.layout import FRAME, FRAME_NOTE, LAYOUT_VERSION, grid_to_attrs

    run = KaimalRun.from_mapping({"grid": {"nt": 64, "ny": 4, "nz": 4, "x_m": [0.0]}})
    attrs = {**run.to_attrs(), "turbgen_version": "1", "created_utc": "2026-01-01T00:00:00Z",
             "layout_version": LAYOUT_VERSION, "frame": FRAME, "frame_note": FRAME_NOTE,
             "grid": grid_to_attrs(run.grid), "turbgen_complete": True}
    validate_attrs(attrs, where="s", error=ValueError)  # a valid store's attributes
    attrs["model"] = "karman"
    with pytest.raises(ValueError, match=r"^s: attribute model: 'karman' is not one of mann, kaimal$"):
        validate_attrs(attrs, where="s", error=ValueError)
