"""The model registry: the one place where a turbulence model declares every part of it.

A model (``mann``, ``kaimal``) is one :class:`ModelDeclaration` in :data:`DECLARATIONS`: its run spec, run schema,
options, command, run (memory, out of core, shared part), synthesis, the validator's theory and the lidar preview
theories. Every part but the name and the schema is a reference ``"turbgen.<layer>.<module>:<attribute>"``: the
registry imports nothing (``turbgen --help`` reads it without numpy).

Why references. The layers import downwards only (cli/service/sweep -> api -> runs -> lidar -> validate|export ->
store -> synthesis -> spec -> theory; import-linter checks it). The registry must sit where every reader can see it
(the store checks a store's ``model`` attribute; spec is below it), so it cannot import the layers above. A
reference is resolved by :func:`resolve` with the layer it must lie in, named by the caller, which is that layer or
one above it: the validator asks for ``"validation"`` references, the lidar for ``"virtual_lidar"`` ones, the runs for
``"spec"`` and ``"runs"`` ones. :func:`resolve` refuses a reference outside the layer named, so a declaration that
points into the wrong layer fails at once, and a lower layer never reaches up through the registry
(tests/spec/test_models.py resolves every reference of every declaration from its layer). The readers are:

* turbgen.store.layout ``MODELS`` (the store's ``model`` attribute): the names;
* turbgen.runs.models ``MODELS`` / ``get_model`` (sweeps, the service): ``runner``;
* turbgen.validation.expectations ``theory_for``: ``validator_theory``;
* turbgen.virtual_lidar.preview ``MODELS`` / ``preview_spectra`` and turbgen.virtual_lidar.report: ``preview`` and ``store_preview``;
* turbgen.cli ``COMMANDS``: ``command``; turbgen.api.keywords: ``options``.

A further model is one declaration here (the one existing file it edits) plus six files of its own: spec (its run
class), schema, synthesis, runs (its Model), validate (its theory) and cli (its command). Lidar previews are optional
(None: ``turbgen lidar`` refuses its stores in one line); its one-call ``turbgen.<name>()`` is a function of
turbgen.api (two more files) and sweeps need its presets (turbgen.spec.presets, preset_runs).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from turbgen.errors import ParameterError


@dataclass(frozen=True)
class ModelDeclaration:
    """Everything turbgen knows of one model.

    Parameters
    ----------
    name : str
        The model's name: the store's ``model`` attribute, the command, ``turbgen.<name>``.
    schema : str
        Its run schema, turbgen/schemas/<schema>.schema.json (run files, service requests, keywords).
    spec : str
        ``turbgen.spec`` reference: the run class (``from_mapping``, ``to_attrs``, ``from_attrs``, ``parameters``).
    options : str
        ``turbgen.spec`` reference: the mapping command option / API keyword -> run-mapping key.
    replaces : str
        ``turbgen.spec`` reference: the mapping given run key -> keys it removes from the run file and the preset
        (turbgen.spec.run_inputs.merge_run_inputs).
    command : str
        ``turbgen.cli`` reference: the click command.
    runner : str
        ``turbgen.runs`` reference: the turbgen.runs.models.Model (run, memory, shared part).
    synthesis : str
        ``turbgen.synthesis`` reference: the generator class (documentation; resolved by the registry's test).
    validator_theory : str
        ``turbgen.validation`` reference: ``theory(attrs, design) -> Theory``.
    preview : str or None
        ``turbgen.virtual_lidar`` reference: ``preview(lidar, U_m_s, *, preset, f_hz, radius_m, frozen, **options)`` ->
        PreviewSpectra, the theory of ``turbgen theory lidar``; None: not available.
    store_preview : str or None
        ``turbgen.virtual_lidar`` reference: ``store_preview(fs, description, f_hz, radius_m)`` -> PreviewSpectra of a
        store as synthesised (``turbgen lidar``); None: not available.
    """

    name: str
    schema: str
    spec: str
    options: str
    replaces: str
    command: str
    runner: str
    synthesis: str
    validator_theory: str
    preview: str | None = None
    store_preview: str | None = None


DECLARATIONS: tuple[ModelDeclaration, ...] = (
    ModelDeclaration(
        name="mann", schema="mann-run", spec="turbgen.spec.mann:MannRun",
        options="turbgen.spec.run_inputs:MANN_OPTIONS", replaces="turbgen.spec.run_inputs:MANN_REPLACES",
        command="turbgen.cli.mann:mann", runner="turbgen.runs.models:MANN",
        synthesis="turbgen.synthesis.mann_spacetime:MannSnapshots",
        validator_theory="turbgen.validation.mann_expectation:mann_theory",
        preview="turbgen.virtual_lidar.preview:mann_preview", store_preview="turbgen.virtual_lidar.report:mann_store_preview",
    ),
    ModelDeclaration(
        name="kaimal", schema="kaimal-run", spec="turbgen.spec.kaimal:KaimalRun",
        options="turbgen.spec.run_inputs:KAIMAL_OPTIONS", replaces="turbgen.spec.run_inputs:KAIMAL_REPLACES",
        command="turbgen.cli.kaimal:kaimal", runner="turbgen.runs.models:KAIMAL",
        synthesis="turbgen.synthesis.kaimal_evo:KaimalEvo",
        validator_theory="turbgen.validation.kaimal_expectation:kaimal_theory",
        preview="turbgen.virtual_lidar.preview:kaimal_preview", store_preview="turbgen.virtual_lidar.report:kaimal_store_preview",
    ),
)
_BY_NAME = {d.name: d for d in DECLARATIONS}


def model_names() -> tuple[str, ...]:
    """The declared models' names, in declaration order.

    Returns
    -------
    tuple of str
        ("mann", "kaimal").
    """
    return tuple(_BY_NAME)


def declaration(name: str, what: str = "model") -> ModelDeclaration:
    """The declaration of model ``name``.

    Parameters
    ----------
    name : str
        The model's name.
    what : str, optional
        How the value is named in the message (e.g. "store model").

    Returns
    -------
    ModelDeclaration
        Its declaration.

    Raises
    ------
    ParameterError
        Naming the value and the declared models.
    """
    if name not in _BY_NAME:
        raise ParameterError(f"{what} = {name!r} is not one of {', '.join(_BY_NAME)}")
    return _BY_NAME[name]


def resolve(reference: str, layer: str):
    """The object a declaration's reference names, imported from ``layer``.

    Parameters
    ----------
    reference : str
        ``"turbgen.<layer>.<module>:<attribute>"``.
    layer : str
        The layer the reference must lie in (``"spec"``, ``"runs"``, ``"validation"``, ``"virtual_lidar"``, ``"cli"``, ...): the
        caller's own layer or one below it, never one above.

    Returns
    -------
    object
        The attribute.

    Raises
    ------
    ValueError
        For a reference outside ``layer`` (a wrong declaration: a programming error, not user input).
    """
    module, _, attribute = reference.partition(":")
    if not module.startswith(f"turbgen.{layer}.") or not attribute:
        raise ValueError(f"model reference {reference!r} is not a turbgen.{layer} attribute")
    return getattr(importlib.import_module(module), attribute)
