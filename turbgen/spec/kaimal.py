"""What a Kaimal 4D run is: IEC spectra + yz coherence, longitudinal coherence, grid, speed and seed.

``KaimalRun.from_mapping`` reads a run file / request / preset mapping (schemas/kaimal-run.schema.json)
with turbgen.spec.defaults; ``to_attrs`` / ``from_attrs`` write and read the store attributes;
turbgen.runs.kaimal generates the field. Values are checked against turbgen.theory.ranges."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import partial

from turbgen.errors import ParameterError, check_choice, check_instances
from turbgen.grid import Grid
from turbgen.spec.defaults import DEFAULT_A_X, DEFAULT_B_X, KAIMAL_DEFAULTS, KAIMAL_GRID, grid_from_mapping
from turbgen.spec.naming import run_digest
from turbgen.spec.user_spectrum import line_coherence, line_spectrum
from turbgen.theory import ranges
from turbgen.theory.coherence_models import LONGITUDINAL_MODELS, simley_pao_parameters
from turbgen.theory.kaimal import IEC_SIGMA_RATIOS, iec_kaimal_params
from turbgen.theory.params import KaimalParams, check_wind_speed
from turbgen.theory.user_coherence import LineCoherence
from turbgen.theory.user_spectra import LineSpectrum

LONG_COMPONENTS = ("u", "uvw")
VW_COHERENCE = ("white", "exp")
UNITS = {
    "U_m_s": "m s-1", "turb_class": "", "hub_height_m": "m", "sigma_m_s": "m s-1", "length_scales_m": "m",
    "a_yz": "1", "lc_m": "m", "long_model": "", "a_x": "1", "b_x": "m-1", "long_components": "",
    "vw_coherence": "", "rescale": "", "seed": "1", "effective_long_parameters": "a_x: 1, b_x: m-1",
    "resolved_band_hz": "Hz", "expected_sigma_m_s": "m s-1", "rescale_factors": "1", "freq_chunk": "1",
    "spectrum": "f_hz: Hz, S_u S_v S_w: m2 s-1 (band means on the run's lines)",
    "coherence": "f_hz: Hz, r_m: m, coh: 1 (yz coherence on the run's lines)",
}  # fmt: skip
# the store's 'derived' attribute (worked out from the inputs; older stores kept them among the parameters)
DERIVED_KEYS = ("effective_long_parameters", "resolved_band_hz", "expected_sigma_m_s", "rescale_factors",
                "freq_chunk")  # fmt: skip
_INPUT_KEYS = set(UNITS) - set(DERIVED_KEYS)
# option name (`turbgen kaimal`, turbgen.kaimal) -> key of the run mapping (schemas/kaimal-run.schema.json)
OPTIONS = {
    "U": "U_m_s", "turb_class": "turb_class", "hub_height": "hub_height_m", "sigma": "sigma_m_s",
    "lengths": "length_scales_m", "ayz": "a_yz", "lc": "lc_m", "long_model": "long_model", "ax": "a_x",
    "bx": "b_x", "long_components": "long_components", "vw_coherence": "vw_coherence", "rescale": "rescale",
    "seed": "seed", "spectrum": "spectrum",
}  # fmt: skip
REPLACES = {"sigma_m_s": ("turb_class",)}  # given sigmas: no class to record
DEFAULTS = {**KAIMAL_DEFAULTS, **KAIMAL_GRID}  # the run keys' and grid keys' defaults (the service form shows them)


@dataclass(frozen=True)
class KaimalRun:
    """A Kaimal 4D field (Guo et al. 2023, Eq. 11-12, 18): spectra + yz coherence, grid, U, seed, longitudinal model.

    ``long_model``: "exp" (Eq. 18 with ``a_x`` [-], ``b_x`` [1/m]; defaults Table 2 neutral), "simley-pao" (Eq. 18
    with Simley and Pao 2015) or "kristensen" (Kristensen 1979). With a user ``spectrum`` the sigmas become the
    spectrum's; L1 enters only the Simley-Pao and Kristensen coherences. ParameterError for a value outside its range,
    an unknown choice, a_x / b_x with another model, or ``rescale`` with ``spectrum``."""

    kaimal: KaimalParams  # sigma_u,v,w [m/s], L1..L3 [m], a_yz [-], Lc [m]
    grid: Grid
    U_m_s: float
    seed: int
    hub_height_m: float = 150.0
    long_model: str = "exp"
    a_x: float | None = None
    b_x: float | None = None
    long_components: str = "u"  # "u" (evoTurb) or "uvw"
    rescale: bool = False  # expected variance = nominal sigma^2 (else the resolved-band integral of Eq. 11)
    vw_coherence: str = "white"  # "white" (IEC / TurbSim IECKAI) or "exp" (u's)
    turb_class: str | None = None  # recorded only
    spectrum: LineSpectrum | None = None  # user spectrum on the grid's lines in place of Kaimal's
    coherence: LineCoherence | None = None  # user yz coherence on the grid's lines in place of the IEC exponential

    def __post_init__(self):
        check_instances(params=(self.kaimal, KaimalParams), grid=(self.grid, Grid))
        object.__setattr__(self, "U_m_s", check_wind_speed(self.U_m_s))
        for key in ("seed", "hub_height_m"):  # ranges: turbgen.theory.ranges
            object.__setattr__(self, key, ranges.check(key, getattr(self, key)))
        ranges.check_grid(self.grid)
        check_choice("long_model", self.long_model, tuple(LONGITUDINAL_MODELS))
        check_choice("long_components", self.long_components, LONG_COMPONENTS)
        check_choice("vw_coherence", self.vw_coherence, VW_COHERENCE)
        if self.long_model == "exp":
            object.__setattr__(self, "a_x", DEFAULT_A_X if self.a_x is None else ranges.check("a_x", self.a_x))
            object.__setattr__(self, "b_x", DEFAULT_B_X if self.b_x is None else ranges.check("b_x", self.b_x))
        elif self.a_x is not None or self.b_x is not None:
            raise ParameterError(f"a_x / b_x apply to long_model exp only, not {self.long_model!r}")
        object.__setattr__(self, "rescale", bool(self.rescale))
        if self.spectrum is not None:
            if self.rescale:
                raise ParameterError("rescale = true applies to the Kaimal spectra, not to a user spectrum (scale "
                                     "the spectrum instead)")
            spectrum = line_spectrum(self.spectrum, self.grid)
            # the run's sigmas are the spectrum's as the lines realise it (recorded; Simley-Pao, Kristensen read them)
            sigma = [ranges.check("sigma_m_s", math.sqrt(v), f"the spectrum's sigma_{c} (m/s)")
                     for c, v in zip("uvw", spectrum.line_variances().sum(axis=1))]  # fmt: skip
            object.__setattr__(self, "spectrum", spectrum)
            object.__setattr__(self, "kaimal", replace(self.kaimal, sigma_m_s=tuple(sigma)))
        object.__setattr__(self, "coherence", line_coherence(self.coherence, self.grid, self.U_m_s))

    @property
    def model(self) -> str:
        """The model name, "kaimal" (the key of turbgen.runs.models.MODELS)."""
        return "kaimal"

    @property
    def sigma_total_m_s(self) -> float:
        """sqrt(sigma_u^2 + sigma_v^2 + sigma_w^2) [m/s] (Simley-Pao and Kristensen models)."""
        return math.sqrt(sum(s * s for s in self.kaimal.sigma_m_s))

    def long_coherence(self):
        """The chosen un-squared longitudinal coherence as ``f(dx_m, f_hz)`` [-]."""
        if self.long_model == "exp":
            return partial(LONGITUDINAL_MODELS["exp"], U_m_s=self.U_m_s, a_x=self.a_x, b_x=self.b_x)
        return partial(LONGITUDINAL_MODELS[self.long_model], U_m_s=self.U_m_s,
                       sigma_total_m_s=self.sigma_total_m_s, length_u_m=self.kaimal.length_scales_m[0])

    def effective_long_parameters(self) -> dict:
        """The a_x [-], b_x [1/m] actually used (Simley-Pao derives them; empty for Kristensen)."""
        if self.long_model == "simley-pao":
            a_x, b_x = simley_pao_parameters(self.sigma_total_m_s, self.U_m_s, self.kaimal.length_scales_m[0])
            return {"a_x": a_x, "b_x": b_x}
        if self.long_model == "exp":
            return {"a_x": self.a_x, "b_x": self.b_x}
        return {}

    def default_store_name(self, preset: str | None = None, preset_keys: Mapping | None = None) -> str:
        """A readable store name, e.g. kaimal_U16_A_s1.zarr or kaimal_U16_stable_s1.zarr (``preset`` named); a run
        that differs from the named one in anything else gets ``_p<8 hex digits>`` of all that determines the field."""
        label = preset or self.turb_class or "sigma"
        base = f"kaimal_U{self.U_m_s:g}_{label}_s{self.seed}"
        named = {"U_m_s": self.U_m_s, "seed": self.seed}
        if preset is not None:
            named.update(preset_keys or {})
        if self.turb_class:
            named["turb_class"] = self.turb_class
        reference = KaimalRun.from_mapping(named) if (preset is not None or self.turb_class) else None
        if reference is not None and reference.parameters() == self.parameters() and reference.grid == self.grid:
            return base + ".zarr"
        return f"{base}_p{run_digest(self.parameters(), self.grid)}.zarr"

    def parameters(self) -> dict:
        """Every input parameter as JSON values, the keys :meth:`from_mapping` reads back (user spectrum and
        coherence as their ``to_table``)."""
        k = self.kaimal
        return {
            "U_m_s": self.U_m_s, "turb_class": self.turb_class or "", "hub_height_m": self.hub_height_m,
            "sigma_m_s": list(k.sigma_m_s), "length_scales_m": list(k.length_scales_m), "a_yz": k.a_yz,
            "lc_m": k.lc_m, "long_model": self.long_model, "a_x": self.a_x, "b_x": self.b_x,
            "long_components": self.long_components, "vw_coherence": self.vw_coherence, "rescale": self.rescale,
            "seed": self.seed,
            **({} if self.spectrum is None else {"spectrum": self.spectrum.to_table()}),
            **({} if self.coherence is None else {"coherence": self.coherence.to_table()}),
        }  # fmt: skip

    def to_attrs(self, derived: Mapping | None = None) -> dict:
        """The store attributes (model, parameters, derived: what the generator worked out, units, seed, U_m_s,
        hub_height_m; not the grid); None parameters are left out."""
        params = {key: v for key, v in self.parameters().items() if v is not None}
        out = {"effective_long_parameters": self.effective_long_parameters(), **(derived or {})}
        return {"model": "kaimal", "parameters": params, "derived": out,
                "units": {key: UNITS[key] for key in (*params, *out)}, "seed": self.seed, "U_m_s": self.U_m_s,
                "hub_height_m": self.hub_height_m}

    @classmethod
    def from_attrs(cls, attrs: Mapping) -> "KaimalRun":
        """The run that wrote a store, from its ``parameters`` and ``grid`` attributes (derived values ignored);
        ParameterError if they lack the Kaimal run or hold invalid values."""
        try:
            inputs = {k: v for k, v in attrs["parameters"].items() if k not in DERIVED_KEYS}
            return cls.from_mapping({**inputs, "grid": attrs["grid"]})
        except (KeyError, TypeError, AttributeError) as exc:
            raise ParameterError(f"store parameters lack the Kaimal run ({exc}); not a turbgen Kaimal store") from None

    @classmethod
    def from_mapping(cls, d: Mapping) -> "KaimalRun":
        """A run from a (schema-valid) mapping of :meth:`parameters`' keys and ``grid`` (missing: turbgen.spec.defaults,
        the IEC sigmas and lengths of ``turb_class`` and ``hub_height_m``); ParameterError for a bad key or value."""
        unknown = set(d) - _INPUT_KEYS - {"grid"}
        if unknown:
            raise ParameterError(f"kaimal config: unknown keys {sorted(unknown)}")
        v = {**KAIMAL_DEFAULTS, **{k: val for k, val in d.items() if k != "grid"}}
        grid = grid_from_mapping(d.get("grid"), KAIMAL_GRID)
        explicit = d.get("sigma_m_s") is not None
        kaimal = kaimal_params(v["U_m_s"], v["turb_class"] or "A", v["hub_height_m"], d.get("sigma_m_s"),
                               d.get("length_scales_m"), d.get("a_yz"), d.get("lc_m"))
        return cls(kaimal=kaimal, grid=grid, U_m_s=v["U_m_s"], seed=v["seed"], hub_height_m=v["hub_height_m"],
                   long_model=v["long_model"], a_x=d.get("a_x"), b_x=d.get("b_x"),
                   long_components=v["long_components"], rescale=v["rescale"], vw_coherence=v["vw_coherence"],
                   turb_class=d.get("turb_class") or (None if explicit else KAIMAL_DEFAULTS["turb_class"]),
                   spectrum=line_spectrum(d.get("spectrum"), grid), coherence=d.get("coherence"))


def kaimal_params(U_m_s: float, turb_class: str = "A", hub_height_m: float = 90.0, sigma_m_s=None,
                  length_scales_m=None, a_yz: float | None = None, lc_m: float | None = None) -> KaimalParams:
    """IEC Kaimal parameters at hub speed ``U_m_s`` [m/s] of class ``turb_class`` ("A+", "A", "B", "C") and hub
    height [m]; ``sigma_m_s`` [m/s], ``length_scales_m`` L1..L3 [m], ``a_yz`` [-], ``lc_m`` [m] replace IEC's."""
    iec = iec_kaimal_params(U_m_s, turb_class, hub_height_m)
    return KaimalParams(
        sigma_m_s=tuple(sigma_m_s) if sigma_m_s is not None else iec.sigma_m_s,
        length_scales_m=tuple(length_scales_m) if length_scales_m is not None else iec.length_scales_m,
        a_yz=iec.a_yz if a_yz is None else a_yz,
        lc_m=iec.lc_m if lc_m is None else lc_m,
    )


def load_case_keys(keys: Mapping, sigma1_m_s: float) -> dict:
    """The run keys ``keys`` (a preset's) for an IEC load case (turbgen.spec.dlc): sigma 1, 0.8, 0.5 sigma1 [m/s]
    and the IEC length scales of the run's hub height (IEC 61400-1 Annex C)."""
    out = {k: v for k, v in keys.items() if k not in ("length_scales_m", "lc_m")}
    return {**out, "sigma_m_s": [r * sigma1_m_s for r in IEC_SIGMA_RATIOS]}
