"""The model registry: the one place where a turbulence model (``mann``, ``kaimal``) declares every part of it.

Each part but the name and schema is a reference ``"turbgen.<layer>.<module>:<attribute>"``, so the registry imports
nothing (``turbgen --help`` reads it without numpy) and every layer can read it. :func:`resolve` imports a reference
only from the layer its caller names (its own or one below), so a declaration pointing into the wrong layer fails at
once and no lower layer reaches up through the registry (tests/spec/test_models.py resolves each from its layer).

A further model touches 6 files: a ``_declare`` line here, spec/<name>.py (run class, OPTIONS, REPLACES, DEFAULTS),
schemas/<name>-run.schema.json, its synthesis module, runs/<name>.py (run, MODEL), validation/<name>_expectation.py;
its command (turbgen.cli.model), store, validator, sweeps and service page read this registry. Optional: own command,
preset keys (sweeps need them), lidar previews, DLC sets, ``turbgen.<name>()``, a sweep file's per-model grid table
(tests/spec/test_models.py keeps other modules from naming a model)."""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from turbgen.errors import ParameterError


@dataclass(frozen=True)
class ModelDeclaration:
    """Everything turbgen knows of one model: references into the layer a comment names (None: not available)."""

    name: str  # the store's ``model`` attribute, the command, ``turbgen.<name>``
    schema: str  # turbgen/schemas/<schema>.schema.json
    spec: str  # spec: the run class (``from_mapping``, ``to_attrs``, ``from_attrs``, ``parameters``)
    options: str  # spec: option / keyword -> run key
    replaces: str  # spec: given run key -> keys it removes from the run file and the preset
    defaults: str  # spec: run and grid key -> default
    runner: str  # runs: the turbgen.runs.models.Model
    synthesis: str  # the generator class (resolved by the registry's test only)
    validator_theory: str  # validation: ``theory(attrs, design) -> Theory``
    command: str | None = None  # the click command (None: turbgen.cli.model builds one from the declaration)
    presets: str | None = None  # spec: ``keys(preset, U_m_s, *, user, turb_class)`` -> a stability preset's run keys
    # virtual_lidar: ``preview(lidar, U_m_s, *, preset, f_hz, radius_m, frozen, **options)`` and
    # ``store_preview(fs, description, f_hz, radius_m)``, both -> PreviewSpectra
    preview: str | None = None
    store_preview: str | None = None
    load_case: str | None = None  # spec: ``load_case(keys, sigma1_m_s)`` -> the preset's keys at an IEC sigma1 [m/s]
    summary: str = "A 4D turbulence field."  # the command's line in ``turbgen --help``


def _declare(name: str, run_class: str, synthesis: str, **optional) -> ModelDeclaration:
    """The declaration of model ``name`` whose required parts sit where the convention puts them (module and names
    from it); ``optional``: the references of its optional parts."""
    return ModelDeclaration(
        name=name, schema=f"{name}-run", spec=f"turbgen.spec.{name}:{run_class}",
        options=f"turbgen.spec.{name}:OPTIONS", replaces=f"turbgen.spec.{name}:REPLACES",
        defaults=f"turbgen.spec.{name}:DEFAULTS", runner=f"turbgen.runs.{name}:MODEL", synthesis=synthesis,
        validator_theory=f"turbgen.validation.{name}_expectation:{name}_theory", **optional,
    )


def _own(name: str) -> dict:
    """The optional parts mann and kaimal have: own command, presets, lidar previews, DLC sets."""
    return dict(command=f"turbgen.cli.{name}:{name}", presets=f"turbgen.spec.preset_runs:{name}_run_keys",
                load_case=f"turbgen.spec.{name}:load_case_keys",
                preview=f"turbgen.virtual_lidar.preview:{name}_preview",
                store_preview=f"turbgen.virtual_lidar.report:{name}_store_preview")


DECLARATIONS: tuple[ModelDeclaration, ...] = (
    _declare("mann", "MannRun", "turbgen.synthesis.mann_spacetime:MannSnapshots", **_own("mann"),
             summary="Mann space-time 4D field: the sheared tensor, evolving eddies."),
    _declare("kaimal", "KaimalRun", "turbgen.synthesis.kaimal_evo:KaimalEvo", **_own("kaimal"),
             summary="Kaimal 4D field: IEC spectra, yz and longitudinal coherence."),
)
_BY_NAME = {d.name: d for d in DECLARATIONS}


def model_names() -> tuple[str, ...]:
    """The declared models' names in declaration order: ("mann", "kaimal")."""
    return tuple(_BY_NAME)


def declaration(name: str, what: str = "model") -> ModelDeclaration:
    """The declaration of model ``name``; ParameterError naming it as ``what`` (e.g. "store model") if unknown."""
    if name not in _BY_NAME:
        raise ParameterError(f"{what} = {name!r} is not one of {', '.join(_BY_NAME)}")
    return _BY_NAME[name]


def resolve(reference: str, layer: str):
    """The attribute ``reference`` (``"turbgen.<layer>.<module>:<attribute>"``) names, imported from ``layer`` (the
    caller's own or one below it); ValueError for a reference outside it (a wrong declaration, not user input)."""
    module, _, attribute = reference.partition(":")
    if not module.startswith(f"turbgen.{layer}.") or not attribute:
        raise ValueError(f"model reference {reference!r} is not a turbgen.{layer} attribute")
    return getattr(importlib.import_module(module), attribute)
