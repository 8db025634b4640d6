"""What a Mann space-time run is: parameters + grid + seed (Guo et al. 2023, Sect. 2.3.1), apart from how it runs.

``from_mapping`` reads a run file / request / preset mapping (schemas/mann-run.schema.json); ``to_attrs`` /
``from_attrs`` write and read the store attributes. Values are checked against turbgen.theory.ranges."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError, check_instances
from turbgen.grid import Grid
from turbgen.spec.defaults import MANN_DEFAULTS, MANN_GRID, grid_from_mapping
from turbgen.spec.energy import resolve_ae
from turbgen.spec.naming import run_digest
from turbgen.theory import ranges
from turbgen.theory.params import MannParams, check_wind_speed

UNITS = {
    "ae": "m4/3 s-2", "length_scale_m": "m", "gamma": "1", "lifetime": "", "factor1": "1", "factor2": "1",
    "evo_time_s": "s", "U_m_s": "m s-1", "seed": "1", "hub_height_m": "m", "pad_yz": "1", "ae_from": "",
}  # fmt: skip
DERIVED_KEYS = ("ae_from",)  # the store's 'derived' attribute: how ae was chosen (text)
_INPUT_KEYS = set(UNITS) | {"sigma_u_m_s", "ti", "turb_class", "grid"}
# option name (`turbgen mann`, turbgen.mann) -> key of the run mapping (schemas/mann-run.schema.json)
OPTIONS = {
    "U": "U_m_s", "L": "length_scale_m", "gamma": "gamma", "evo": "evo_time_s", "lifetime": "lifetime",
    "factor1": "factor1", "factor2": "factor2", "seed": "seed", "hub_height": "hub_height_m", "pad_yz": "pad_yz",
    "ae": "ae", "sigma_u": "sigma_u_m_s", "ti": "ti",
    "constrain": "constrain", "noise": "noise_m_s", "conditional_mean": "conditional_mean", "fit": "fit",
}  # fmt: skip
# a given energy level replaces any from the run file or the preset: one level, one source
ENERGY_KEYS = ("ae", "sigma_u_m_s", "ti")
REPLACES = {key: (*ENERGY_KEYS, "ae_from") for key in ENERGY_KEYS}
DEFAULTS = {**MANN_DEFAULTS, **MANN_GRID}  # the run keys' and grid keys' defaults (the service form shows them)


@dataclass(frozen=True)
class MannRun:
    """Everything that determines a Mann space-time field (Guo et al. 2023, Sect. 2.3.1): parameters, grid (dx = U
    dt), U [m/s], seed, hub height [m] (for exports), ``pad_yz`` (synthesis box that many times wider in y and z,
    cropped) and ``ae_from`` (how ae was chosen, recorded in the store)."""

    params: MannParams
    grid: Grid
    U_m_s: float
    seed: int
    hub_height_m: float = 150.0
    pad_yz: int = 2
    ae_from: str = "ae"

    def __post_init__(self):
        check_instances(params=(self.params, MannParams), grid=(self.grid, Grid))
        object.__setattr__(self, "U_m_s", check_wind_speed(self.U_m_s))
        for key in ("seed", "hub_height_m", "pad_yz"):  # ranges: turbgen.theory.ranges
            object.__setattr__(self, key, ranges.check(key, getattr(self, key)))
        ranges.check_grid(self.grid)

    @property
    def model(self) -> str:
        """The model name, "mann" (the key of turbgen.runs.models.MODELS)."""
        return "mann"

    def plane_times_s(self) -> np.ndarray:
        """Relative snapshot time t_n = x_n / U [s] of each plane, in storage order."""
        return self.grid.x() / self.U_m_s

    def parameters(self) -> dict:
        """The keys of the run mapping that rebuild this run with its grid, ae_from included (units: ``UNITS``)."""
        p = self.params
        return {
            "ae": p.ae, "length_scale_m": p.length_scale_m, "gamma": p.gamma, "lifetime": p.lifetime,
            "factor1": p.factor1, "factor2": p.factor2, "evo_time_s": p.evo_time_s, "U_m_s": self.U_m_s,
            "seed": self.seed, "hub_height_m": self.hub_height_m, "pad_yz": self.pad_yz, "ae_from": self.ae_from,
        }  # fmt: skip

    def to_attrs(self) -> dict:
        """The store attributes (model, parameters, derived ``ae_from``, units, seed, U_m_s, hub_height_m)."""
        params = self.parameters()
        derived = {key: params.pop(key) for key in DERIVED_KEYS}
        return {"model": "mann", "parameters": params, "derived": derived,
                "units": {k: UNITS[k] for k in (*params, *derived)}, "seed": self.seed, "U_m_s": self.U_m_s,
                "hub_height_m": self.hub_height_m}

    @classmethod
    def from_attrs(cls, attrs: Mapping) -> "MannRun":
        """The run that wrote a store, from its ``parameters``, ``derived`` and ``grid`` attributes (also with
        ``ae_from`` among the parameters); ParameterError if they lack the Mann run or hold invalid values."""
        try:
            return cls.from_mapping({**attrs["parameters"], **attrs.get("derived", {}), "grid": attrs["grid"]})
        except (KeyError, TypeError) as exc:
            raise ParameterError(f"store parameters lack the Mann run ({exc}); not a turbgen Mann store") from None

    def default_store_name(self) -> str:
        """A readable store name, e.g. mann_U16_L49_G3.1_evo400_s1.zarr; a run that differs from the named one in
        anything the name does not show gets ``_p<8 hex digits>`` of all that determines the field."""
        p = self.params
        evo = "frozen" if p.evo_time_s is None else f"{p.evo_time_s:g}"
        base = f"mann_U{self.U_m_s:g}_L{p.length_scale_m:g}_G{p.gamma:g}_evo{evo}_s{self.seed}"
        named = MannRun.from_mapping({"U_m_s": self.U_m_s, "length_scale_m": p.length_scale_m, "gamma": p.gamma,
                                      "evo_time_s": p.evo_time_s, "seed": self.seed})  # fmt: skip
        if named == self:
            return base + ".zarr"
        return f"{base}_p{run_digest(self.parameters(), self.grid)}.zarr"

    @classmethod
    def from_mapping(cls, d: Mapping) -> "MannRun":
        """A run from a (schema-valid) mapping of :meth:`parameters`' keys (ae_from only with ae), ``sigma_u_m_s``
        [m/s], ``ti`` [-], ``turb_class`` and ``grid``; missing keys take turbgen.spec.defaults, the energy level
        turbgen.spec.energy.resolve_ae's. ParameterError for an unknown key or a value outside its range."""
        unknown = set(d) - _INPUT_KEYS
        if unknown:
            raise ParameterError(f"mann config: unknown keys {sorted(unknown)}")
        v = {**MANN_DEFAULTS, **{k: val for k, val in d.items() if k != "grid"}}
        grid = grid_from_mapping(d.get("grid"), MANN_GRID)
        U = check_wind_speed(v["U_m_s"])
        ranges.check_grid(grid)  # the cheap checks before the energy-level quadrature
        for key in ("seed", "hub_height_m", "pad_yz"):
            ranges.check(key, v[key])
        shape = MannParams(
            ae=1.0, length_scale_m=v["length_scale_m"], gamma=v["gamma"], lifetime=v["lifetime"],
            factor1=v["factor1"], factor2=v["factor2"], evo_time_s=v["evo_time_s"],
        )  # fmt: skip
        ae, ae_from = resolve_ae(shape, U, ae=d.get("ae"), sigma_u_m_s=d.get("sigma_u_m_s"), ti=d.get("ti"),
                                 turb_class=v["turb_class"])
        if d.get("ae") is not None:
            ae_from = d.get("ae_from", ae_from)
        return cls(shape.with_ae(ae), grid, U, v["seed"], v["hub_height_m"], v["pad_yz"], ae_from)


def load_case_keys(keys: Mapping, sigma1_m_s: float) -> dict:
    """The run keys ``keys`` (a preset's) for an IEC load case (turbgen.spec.dlc): sigma_u is its sigma1 [m/s]."""
    return {**keys, "sigma_u_m_s": sigma1_m_s}
