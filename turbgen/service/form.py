"""The run form of the service's page, generated from the run schemas, the commands' option names
(turbgen.spec.run_inputs) and the range table (turbgen.theory.ranges.RANGES): one field per schema key but
:data:`NOT_IN_FORM`, named as the command's option (``-`` written ``_``), with its range, unit and default."""

from __future__ import annotations

import re
from dataclasses import asdict, dataclass

from turbgen.spec.config import load_schema
from turbgen.spec.models import declaration, model_names, resolve
from turbgen.spec.presets import BUILTIN_PRESETS
from turbgen.spec.run_inputs import GRID_OPTIONS
from turbgen.theory.ranges import LIMITS, RANGES

MODELS = model_names()  # the registry's models (turbgen.spec.models)
GROUPS = ("model", "energy", "grid", "planes", "mean wind / export", "constraints")
OPTIONS = {m: resolve(declaration(m).options, "spec") for m in MODELS}
DEFAULTS = {m: resolve(declaration(m).defaults, "spec") for m in MODELS}
# run-mapping key -> group on the page (keys absent here are in "model")
_GROUP_OF = {
    "ae": "energy", "sigma_u_m_s": "energy", "ti": "energy", "turb_class": "energy", "sigma_m_s": "energy",
    "nt": "grid", "dt_s": "grid", "ny": "grid", "nz": "grid", "dy_m": "grid", "dz_m": "grid",
    "x_m": "planes", "gates": "planes", "U_m_s": "mean wind / export", "hub_height_m": "mean wind / export",
    "constrain": "constraints", "noise_m_s": "constraints", "conditional_mean": "constraints", "fit": "constraints",
}  # fmt: skip
# schema keys the form does not show, and why
NOT_IN_FORM = {
    ("mann", "ae_from"): "text the store records about how ae was set, not an input",
    ("mann", "turb_class"): "no option of `turbgen mann` (ae, sigma_u or ti set the energy level)",
    ("kaimal", "spectrum"): "a table of four columns: the request body's `spectrum` (f_hz, S_u, S_v, S_w), not a field",
    ("kaimal", "coherence"): "a table (f_hz x r_m): the request body's `coherence` (f_hz, r_m, coh), not a field",
}
# keys with a field kind of their own (the others' follows their schema type)
_OWN_KINDS = {"evo_time_s": "evo", "x_m": "positions", "constrain": "upload"}
# fields that are no schema key: the preset (as --preset) and the range gates (as --gates, giving grid.x_m)
_PRESET_HELP = "stability preset: sets the model's stability keys at U; fields given here override it"
_GATES_HELP = "range gates start:stop:step [m]; planes = the rotor 0 plus the gates (instead of planes)"
# meanings the schema does not give (else: its description, else the range table's note)
_EXTRA = {
    "evo_time_s": "evolution time gamma [s] of the eddy lifetime, or frozen",
    "constrain": "upload a point-series JSON or CSV, or a line-of-sight CSV file (as --constrain FILE)",
    "long_model": "longitudinal coherence model between planes", "rescale": "scale the spectra so the expected "
    "sigma is the nominal one", "long_components": "components given the longitudinal coherence (evoTurb: u)",
    "vw_coherence": "v, w in the yz plane: white (IEC) or exp (u's coherence)",
}  # fmt: skip


@dataclass(frozen=True)
class Field:
    """One field of the run form; the fields after ``kind`` are shown beside it."""

    name: str  # the command's option (``L``, ``hub_height``)
    key: str  # where the value goes in the request body (a run key, ``grid.<key>``, ``preset`` or ``gates``)
    group: str  # one of GROUPS
    kind: str  # number, integer, choice, flag, list3, positions, gates, evo or upload
    unit: str = ""
    range: str = ""
    default: str = ""
    help: str = ""
    choices: tuple = ()

    @property
    def flag(self) -> str:
        """The command-line option (``--hub-height``; Kaimal's ``turb_class`` is ``--class``)."""
        return "--class" if self.name == "turb_class" else "--" + self.name.replace("_", "-")


def _unit(spec: dict, key: str) -> str:
    found = re.search(r"\[([^\]]+)\]", spec.get("description", ""))
    if found:
        return found.group(1).split(" upstream")[0]
    for suffix, unit in (("_m_s", "m/s"), ("_m", "m"), ("_s", "s")):
        if key.endswith(suffix):
            return unit
    inner = re.search(r"\(([^)]*), ([^,)]*)\)", RANGES[key].label if key in RANGES else "")
    return inner.group(2) if inner else ""


def _kind(key: str, spec: dict) -> str:
    if key in _OWN_KINDS:
        return _OWN_KINDS[key]
    if "enum" in spec:
        return "choice"
    return {"integer": "integer", "boolean": "flag", "array": "list3"}.get(spec.get("type"), "number")


def _range(key: str, spec: dict) -> str:
    if key in RANGES:
        return RANGES[key].text()
    if key == "noise_m_s":
        return f"[{spec['minimum']:g}, {spec['maximum']:g}]"
    if key == "constrain":
        return f"at most {spec['maxItems']} files"
    return ""


def _default(model: str, key: str) -> str:
    value = DEFAULTS[model].get(key)
    if key == "dz_m":
        return "= dy"
    if key == "ae":
        return "IEC class A sigma_u at U"
    if value is None or isinstance(value, bool):
        return ""
    if isinstance(value, (list, tuple)):
        return ",".join(f"{v:g}" for v in value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def _help(key: str, spec: dict) -> str:
    return _EXTRA.get(key) or spec.get("description") or (RANGES[key].why if key in RANGES else "")


def _field(model: str, key: str, spec: dict, grid: bool) -> Field:
    names = {v: k for k, v in (GRID_OPTIONS if grid else OPTIONS[model]).items()}
    name = "planes" if key == "x_m" else names.get(key, key)
    return Field(name=name, key=f"grid.{key}" if grid else key, group=_GROUP_OF.get(key, "model"),
                 kind=_kind(key, spec), unit=_unit(spec, key), range=_range(key, spec),
                 default=_default(model, key), help=_help(key, spec),
                 choices=tuple(v for v in spec.get("enum", ()) if v != ""))  # fmt: skip


def form_fields(model: str) -> list[Field]:
    """The fields of ``model``'s run form (schema keys, preset, range gates) in the order of :data:`GROUPS`."""
    props = load_schema(f"{model}-run")["properties"]
    fields = [Field("preset", "preset", "model", "choice", help=_PRESET_HELP, choices=tuple(sorted(BUILTIN_PRESETS)))]
    fields += [_field(model, k, s, False) for k, s in props.items() if k != "grid" and (model, k) not in NOT_IN_FORM]
    fields += [_field(model, k, s, True) for k, s in props["grid"]["properties"].items()]
    planes = next(f for f in fields if f.key == "grid.x_m")
    fields.append(Field("gates", "gates", "planes", "gates", "m", f"at most {LIMITS['planes'] - 1} gates",
                        "50:169.7:13.3", _GATES_HELP))  # fmt: skip
    fields[fields.index(planes)] = Field(**{**asdict(planes), "range": f"{RANGES['x_m'].text()}, increasing, at most "
                                            f"{LIMITS['planes']} planes"})  # fmt: skip
    return sorted(fields, key=lambda f: GROUPS.index(f.group))


def _label(key: str) -> str:
    """The name a range check gives the value in its message (RANGES' label), "" for a field without one."""
    key = key.removeprefix("grid.")
    return RANGES[key].label if key in RANGES else ""


def form_description(token_required: bool) -> dict:
    """What the page builds its form from (GET /form.json): ``models`` (model -> fields, each with its ``flag``
    and range-check ``label``), ``groups`` and ``token_required``."""
    models = {m: [asdict(f) | {"flag": f.flag, "label": _label(f.key)} for f in form_fields(m)] for m in MODELS}
    return {"models": models, "groups": list(GROUPS), "token_required": token_required}
