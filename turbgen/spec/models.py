"""The model registry: the one place where a turbulence model (``mann``, ``kaimal``) declares every part of it.

Each part but the name and schema is a reference ``"turbgen.<layer>.<module>:<attribute>"``, so the registry imports
nothing (``turbgen --help`` reads it without numpy) and sits low enough for every layer to read (the store checks a
store's ``model``). :func:`resolve` imports a reference only from the layer its caller names (its own or one below:
the validator asks for ``"validation"``, the lidar for ``"virtual_lidar"``, the runs for ``"spec"`` and ``"runs"``),
so a declaration pointing into the wrong layer fails at once and no lower layer reaches up through the registry
(tests/spec/test_models.py resolves every reference from its layer).

A further model touches 6 files: one ``_declare`` line here, spec/<name>.py (run class, OPTIONS, REPLACES,
DEFAULTS), schemas/<name>-run.schema.json, its synthesis module, runs/<name>.py (run, MODEL) and
validation/<name>_expectation.py; its command (turbgen.cli.model), store, validator, sweeps and service page read
this registry. Optional: own command, preset keys (sweeps need them), lidar previews, DLC sets,
``turbgen.<name>()``, a sweep file's per-model grid table (tests/spec/test_models.py keeps other modules from naming
a model)."""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from turbgen.errors import ParameterError


@dataclass(frozen=True)
class ModelDeclaration:
    """Everything turbgen knows of one model.

    Parameters
    ----------
    name, schema, summary : str
        The store's ``model`` attribute, the command, ``turbgen.<name>``; turbgen/schemas/<schema>.schema.json; the
        command's line in ``turbgen --help``.
    spec, options, replaces, defaults : str
        ``turbgen.spec`` references: the run class (``from_mapping``, ``to_attrs``, ``from_attrs``, ``parameters``);
        option / keyword -> run key; given run key -> keys it removes from the run file and the preset; run and
        grid key -> default.
    runner, synthesis, validator_theory : str
        The turbgen.runs.models.Model; the generator class (resolved by the registry's test only); ``theory(attrs,
        design) -> Theory``.
    command, presets : str or None
        The click command (None: turbgen.cli.model builds one from the declaration); ``turbgen.spec``
        ``keys(preset, U_m_s, *, user, turb_class)`` -> the run keys a stability preset sets (None: no presets).
    preview, store_preview : str or None
        ``turbgen.virtual_lidar`` references (None: not available): ``preview(lidar, U_m_s, *, preset, f_hz,
        radius_m, frozen, **options)`` and ``store_preview(fs, description, f_hz, radius_m)``, both -> PreviewSpectra.
    load_case : str or None
        ``turbgen.spec`` ``load_case(keys, sigma1_m_s)`` -> the preset's run keys set to an IEC load case's sigma1
        [m/s] (turbgen.spec.dlc; None: no DLC sets)."""

    name: str
    schema: str
    spec: str
    options: str
    replaces: str
    defaults: str
    runner: str
    synthesis: str
    validator_theory: str
    command: str | None = None
    presets: str | None = None
    preview: str | None = None
    store_preview: str | None = None
    load_case: str | None = None
    summary: str = "A 4D turbulence field."


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
