"""The model registry (turbgen.spec.models): every declared part resolves in its own layer, and the readers agree."""

import pytest

from turbgen.errors import ParameterError
from turbgen.spec.models import DECLARATIONS, declaration, model_names, resolve

# declaration field -> the layer its reference must lie in (the layers of pyproject.toml's import contract)
LAYERS = {"spec": "spec", "options": "spec", "replaces": "spec", "defaults": "spec", "command": "cli", "presets": "spec", "runner": "runs",
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


# files that name a declared model literally (in code, not docstrings) although they are none of its own files, and
# why a further model needs no edit there; a file not listed that names one fails below, so the count cannot grow
NAMES_A_MODEL = {
    "__init__.py": "turbgen.mann / turbgen.kaimal front ends (optional per model)",
    "api/__init__.py": "the same", "spec/run_mapping.py": "the same (their run mappings)",
    "cli/fit_data.py": "`turbgen fit mann` (model fits are per model, optional)",
    "validation/fit/data.py": "the same", "validation/fit/kaimal.py": "the same",
    "spec/preset_files.py": "the presets' mann / kaimal tables (a model's preset keys may read any table)",
    "service/form.py": "mann / kaimal keys the form does not show",
    "cli/sweep.py": "default model", "sweep/dlc.py": "default model", "service/routes/pages.py": "default model",
    "cli/theory_lidar.py": "default model",
    "service/run_ids.py": "default model; constraints: Mann only", "sweep/plan.py": "constraints: Mann only",
    "virtual_lidar/report.py": "mann / kaimal store previews (optional per model)",
    "theory/__init__.py": "module names, not models", "theory/params.py": "the 'mann' eddy lifetime, not a model",
    "theory/eddy_lifetime.py": "the same",
}  # fmt: skip


def own_files(d) -> set:
    """The files model ``d`` has of its own: the modules its references name, its schema, runs/<name>.py."""
    refs = [d.spec, d.options, d.replaces, d.defaults, d.runner, d.synthesis, d.validator_theory, d.command]
    return {r.partition(":")[0].removeprefix("turbgen.").replace(".", "/") + ".py" for r in refs if r} | {
        f"schemas/{d.schema}.schema.json"}


def test_a_further_model_touches_six_files():
    import ast
    from pathlib import Path

    root = Path(__import__("turbgen").__file__).parent
    for d in DECLARATIONS:  # the six: the declaration (models.py) and five of its own, plus the optional command
        required = own_files(d.__class__(**{**d.__dict__, "command": None}))
        assert len({"spec/models.py"} | required) == 6 and all((root / f).is_file() for f in required), required
    allowed = set(NAMES_A_MODEL) | {"spec/models.py"} | set().union(*map(own_files, DECLARATIONS))
    for path in root.rglob("*.py"):
        tree = ast.parse(path.read_text())
        docstrings = {id(n.body[0].value) for n in ast.walk(tree) if isinstance(n, (ast.Module, ast.ClassDef,
                      ast.FunctionDef)) and n.body and isinstance(n.body[0], ast.Expr)}  # fmt: skip
        named = any(isinstance(n, ast.Constant) and n.value in model_names() and id(n) not in docstrings
                    for n in ast.walk(tree))
        assert not named or path.relative_to(root).as_posix() in allowed, path
