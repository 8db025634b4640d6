"""One Kaimal 4D run: KaimalRun (everything that determines the field) -> KaimalEvo -> field store.

Used by ``turbgen kaimal`` and by the sweep, so both give bit-identical stores for the same run.
"""

from __future__ import annotations

import contextlib
import math
import shutil
import time
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
from tqdm import tqdm

from turbgen.errors import ParameterError, check_choice
from turbgen.grid import Grid
from turbgen.resources import available_memory_bytes, format_bytes, require_memory
from turbgen.runs.defaults import DEFAULT_PLANES_M
from turbgen.runs.naming import run_digest
from turbgen.runs.scratch import FileSpectrum
from turbgen.store import create_store
from turbgen.synthesis.kaimal_evo import COMPONENTS, FREQ_CHUNK, KaimalEvo, resolved_band_hz
from turbgen.theory import ranges
from turbgen.theory.coherence_models import LONGITUDINAL_MODELS, simley_pao_parameters
from turbgen.theory.kaimal import iec_kaimal_params
from turbgen.theory.params import KaimalParams, check_wind_speed

# paper 000 Table 2: exponential longitudinal coherence (Eq. 18), neutral class, gamma = 400 s
DEFAULT_A_X = 1.8
DEFAULT_B_X = 1.49e-4  # [1/m]
LONG_COMPONENTS = ("u", "uvw")
VW_COHERENCE = ("white", "exp")
SEED_MAX = 2**63 - 1
# issue 4 default grid: 4096 x 11 x 31 x 31, dt 0.5 s, 150 m x 150 m (dz defaults to dy)
DEFAULT_GRID = {"nt": 4096, "dt_s": 0.5, "ny": 31, "nz": 31, "dy_m": 5.0}


@dataclass(frozen=True)
class KaimalRun:
    """A Kaimal 4D field: spectra + yz coherence (``kaimal``), grid, speed, seed, longitudinal model.

    long_model : "exp" (paper 000 Eq. 18 with a_x [-], b_x [1/m]; defaults Table 2 neutral, gamma = 400 s),
        "simley-pao" (Eq. 18 with the Simley-Pao parameters) or "kristensen" (Kristensen 1979).
    long_components : "u" (evoTurb) or "uvw": components given the longitudinal coherence.
    vw_coherence : "white" (IEC / TurbSim IECKAI: v, w incoherent in yz) or "exp" (extension: the u
        exponential coherence with the same a_yz, Lc).
    rescale : scale each component's spectrum so its expected variance is the nominal sigma^2
        (default: the spectrum follows Eq. 11 and the variance is its resolved-band integral).
    turb_class : IEC class the sigmas came from (recorded only; None for explicit sigmas).
    """

    kaimal: KaimalParams
    grid: Grid
    U_m_s: float
    seed: int
    hub_height_m: float = 90.0
    long_model: str = "exp"
    a_x: float | None = None
    b_x: float | None = None
    long_components: str = "u"
    rescale: bool = False
    vw_coherence: str = "white"
    turb_class: str | None = None

    def __post_init__(self):
        object.__setattr__(self, "U_m_s", check_wind_speed(self.U_m_s))
        for key in ("seed", "hub_height_m"):  # ranges: turbgen.theory.ranges
            object.__setattr__(self, key, ranges.check(key, getattr(self, key)))
        ranges.check_grid(self.grid)
        check_choice("long-model", self.long_model, tuple(LONGITUDINAL_MODELS))
        check_choice("long-components", self.long_components, LONG_COMPONENTS)
        check_choice("vw-coherence", self.vw_coherence, VW_COHERENCE)
        if self.long_model == "exp":
            a_x = DEFAULT_A_X if self.a_x is None else ranges.check("a_x", self.a_x)
            b_x = DEFAULT_B_X if self.b_x is None else ranges.check("b_x", self.b_x)
            object.__setattr__(self, "a_x", a_x)
            object.__setattr__(self, "b_x", b_x)
        elif self.a_x is not None or self.b_x is not None:
            raise ParameterError(f"a_x / b_x apply to long-model exp only, not {self.long_model!r}")
        object.__setattr__(self, "rescale", bool(self.rescale))

    @property
    def sigma_total_m_s(self) -> float:
        """sqrt(sigma_u^2 + sigma_v^2 + sigma_w^2) [m/s] (Simley-Pao and Kristensen models)."""
        return math.sqrt(sum(s * s for s in self.kaimal.sigma_m_s))

    def long_coherence(self):
        """gamma_x(dx_m, f_hz), un-squared, of the chosen longitudinal model."""
        if self.long_model == "exp":
            return partial(LONGITUDINAL_MODELS["exp"], U_m_s=self.U_m_s, a_x=self.a_x, b_x=self.b_x)
        return partial(LONGITUDINAL_MODELS[self.long_model], U_m_s=self.U_m_s,
                       sigma_total_m_s=self.sigma_total_m_s, length_u_m=self.kaimal.length_scales_m[0])

    def effective_long_parameters(self) -> dict:
        """The a_x, b_x actually used (Simley-Pao derives them; Kristensen has none)."""
        if self.long_model == "simley-pao":
            a_x, b_x = simley_pao_parameters(self.sigma_total_m_s, self.U_m_s, self.kaimal.length_scales_m[0])
            return {"a_x": a_x, "b_x": b_x}
        if self.long_model == "exp":
            return {"a_x": self.a_x, "b_x": self.b_x}
        return {}

    def default_store_name(self, preset: str | None = None, preset_keys: Mapping | None = None) -> str:
        """A readable store name, e.g. kaimal_U16_A_s1.zarr or kaimal_U16_stable_s1.zarr (``preset``,
        whose run keys ``preset_keys`` are, from turbgen.presets.kaimal_run_keys).

        Runs that differ from the named ones (U, class or preset, seed) in anything the name does not
        show (sigmas, lengths, coherence models, grid, ...) get ``_p<8 hex digits>`` of everything that
        determines the field appended, so two different fields never share a default name.
        """
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

    def generator(self, workers: int | None = None) -> KaimalEvo:
        """The synthesis object of this run."""
        return KaimalEvo(self.kaimal, self.grid, self.U_m_s, self.seed, long_coherence=self.long_coherence(),
                         long_components=self.long_components, coherent_vw=self.vw_coherence == "exp",
                         rescale=self.rescale, workers=workers)

    def parameters(self) -> dict:
        """Every input parameter (JSON values), the keys :meth:`from_mapping` reads back."""
        k = self.kaimal
        return {
            "U_m_s": self.U_m_s,
            "turb_class": self.turb_class or "",
            "hub_height_m": self.hub_height_m,
            "sigma_m_s": list(k.sigma_m_s),
            "length_scales_m": list(k.length_scales_m),
            "a_yz": k.a_yz,
            "lc_m": k.lc_m,
            "long_model": self.long_model,
            "a_x": self.a_x,
            "b_x": self.b_x,
            "long_components": self.long_components,
            "vw_coherence": self.vw_coherence,
            "rescale": self.rescale,
            "seed": self.seed,
        }

    def to_attrs(self, gen: KaimalEvo | None = None) -> dict:
        """model / parameters / units / seed / U_m_s / hub_height_m for the store (plus synthesis notes).

        ``gen``: this run's generator, if already built (its expected variances are recorded).
        """
        params = {key: v for key, v in self.parameters().items() if v is not None}
        gen = gen or self.generator()
        lo, hi = resolved_band_hz(self.grid.nt, self.grid.dt_s)
        params.update(
            effective_long_parameters=self.effective_long_parameters(),
            resolved_band_hz=[lo, hi],
            expected_sigma_m_s=[math.sqrt(gen.expected_variance(c)) for c in COMPONENTS],
            rescale_factors=[gen.rescale_factors[c] for c in COMPONENTS],
            freq_chunk=FREQ_CHUNK,
        )
        return {
            "model": "kaimal",
            "parameters": params,
            "units": {key: _UNITS[key] for key in params},
            "seed": self.seed,
            "U_m_s": self.U_m_s,
            "hub_height_m": self.hub_height_m,
        }

    @classmethod
    def from_mapping(cls, d: Mapping) -> "KaimalRun":
        """A run from a (validated) mapping: the keys of :meth:`parameters` plus ``grid``.

        Missing keys take the issue-4 defaults; ``turb_class`` + ``hub_height_m`` give the IEC
        sigmas and length scales unless ``sigma_m_s`` / ``length_scales_m`` are given.
        """
        unknown = set(d) - set(_UNITS) - {"grid"}
        if unknown:
            raise ParameterError(f"kaimal config: unknown keys {sorted(unknown)}")
        g = d.get("grid", {})
        if not isinstance(g, Grid):
            g = {**DEFAULT_GRID, "x_m": list(DEFAULT_PLANES_M), **g}
            g = Grid(nt=g["nt"], dt_s=g["dt_s"], x_m=tuple(g["x_m"]), ny=g["ny"], nz=g["nz"], dy_m=g["dy_m"],
                     dz_m=g.get("dz_m", g["dy_m"]))
        U = d.get("U_m_s", 16.0)
        kaimal = kaimal_params(U, d.get("turb_class") or "A", d.get("hub_height_m", 90.0), d.get("sigma_m_s"),
                               d.get("length_scales_m"), d.get("a_yz"), d.get("lc_m"))
        explicit = d.get("sigma_m_s") is not None
        return cls(kaimal=kaimal, grid=g, U_m_s=U, seed=d.get("seed", 1), hub_height_m=d.get("hub_height_m", 90.0),
                   long_model=d.get("long_model", "exp"), a_x=d.get("a_x"), b_x=d.get("b_x"),
                   long_components=d.get("long_components", "u"), rescale=d.get("rescale", False),
                   vw_coherence=d.get("vw_coherence", "white"),
                   turb_class=d.get("turb_class") or (None if explicit else "A"))


_UNITS = {
    "U_m_s": "m s-1", "turb_class": "", "hub_height_m": "m", "sigma_m_s": "m s-1", "length_scales_m": "m",
    "a_yz": "1", "lc_m": "m", "long_model": "", "a_x": "1", "b_x": "m-1", "long_components": "",
    "vw_coherence": "", "rescale": "", "seed": "1", "effective_long_parameters": "a_x: 1, b_x: m-1",
    "resolved_band_hz": "Hz", "expected_sigma_m_s": "m s-1", "rescale_factors": "1", "freq_chunk": "1",
}


def kaimal_params(U_m_s: float, turb_class: str = "A", hub_height_m: float = 90.0, sigma_m_s=None,
                  length_scales_m=None, a_yz: float | None = None, lc_m: float | None = None) -> KaimalParams:
    """IEC Kaimal parameters of a class and hub height, with any of them given explicitly instead."""
    iec = iec_kaimal_params(U_m_s, turb_class, hub_height_m)
    return KaimalParams(
        sigma_m_s=tuple(sigma_m_s) if sigma_m_s is not None else iec.sigma_m_s,
        length_scales_m=tuple(length_scales_m) if length_scales_m is not None else iec.length_scales_m,
        a_yz=iec.a_yz if a_yz is None else a_yz,
        lc_m=iec.lc_m if lc_m is None else lc_m,
    )


def memory_needed(grid: Grid, spill: bool = False) -> int:
    """Peak bytes of a run's arrays: one component's spectrum (nx, nf, ny, nz) complex64 -- or, with
    ``spill`` (the spectrum in a scratch file), one frequency chunk of all planes with its mixing
    copies -- plus one plane in flight (its spectrum copy and float32 field, and the store's
    compression buffers)."""
    nf = grid.nt // 2 + 1
    plane = grid.ny * grid.nz
    in_flight = 2 * nf * plane * 8 + 3 * grid.nt * plane * 4
    if spill:
        return 3 * grid.nx * FREQ_CHUNK * plane * 8 + in_flight
    return grid.nx * nf * plane * 8 + in_flight


def spectrum_bytes(grid: Grid) -> int:
    """Bytes of one component's spectrum (nx, nf, ny, nz) complex64 (in memory, or the scratch file)."""
    return grid.nx * (grid.nt // 2 + 1) * grid.ny * grid.nz * 8


def _plan_spill(grid: Grid, out: Path, spill: bool | None) -> bool:
    """Whether the spectrum goes to a scratch file next to ``out``; checks memory (and disk) first."""
    what = f"the Kaimal spectrum ({grid.nx} planes x {grid.nt // 2 + 1} bins x {grid.ny} x {grid.nz})"
    if spill is None:
        available = available_memory_bytes()
        spill = available is not None and memory_needed(grid) > 0.8 * available
    require_memory(memory_needed(grid, spill), what, "lower --nt, --ny/--nz or the number of planes")
    if spill:
        free = shutil.disk_usage(out.parent).free
        if spectrum_bytes(grid) + 3 * grid.nbytes_per_component() > free:
            raise ParameterError(
                f"{what} does not fit in memory and its {format_bytes(spectrum_bytes(grid))} scratch file plus "
                f"the store do not fit on the disk of {out.parent} ({format_bytes(free)} free); lower --nt, "
                "--ny/--nz or the number of planes"
            )
    return spill


def run_kaimal(run: KaimalRun, out, *, overwrite: bool = False, chunk_t: int | None = None,
               progress: bool = False, threads: int | None = None, spill: bool | None = None) -> dict:
    """Generate the field of ``run`` into the store ``out``; return a summary dict.

    ``threads``: FFT workers (default all cores); the field does not depend on it.
    ``spill``: keep each component's spectrum in an unlinked scratch file next to ``out`` instead
    of memory (None: only when it would not fit in 80 % of the available memory); the field is the same.

    Summary: path, sigma_u/v/w (realised, all points and planes) [m/s], expected_sigma [m/s],
    seconds, and the synthesis report (yz_clip_error, long_clip_error: 0 when exact).
    """
    g = run.grid
    out = Path(out)
    spill = _plan_spill(g, out.absolute(), spill)
    gen = run.generator(workers=threads)
    attrs = run.to_attrs(gen)
    t0 = time.perf_counter()
    sums = {c: [0.0, 0] for c in COMPONENTS}
    with create_store(Path(out), g, attrs, chunk_t=chunk_t, overwrite=overwrite) as w:
        with tqdm(total=3 * (gen.n_chunks + g.nx), desc="kaimal", unit="step", disable=not progress) as bar:
            for c in COMPONENTS:
                with contextlib.ExitStack() as stack:
                    buffer = None
                    if spill:
                        buffer = stack.enter_context(FileSpectrum(out.absolute().parent, g.nx, gen.nf, g.ny, g.nz))
                    for ix, plane in gen.component_planes(c, tick=lambda: bar.update(1), spectrum=buffer):
                        w.write(c, ix, plane)
                        sums[c][0] += float(np.einsum("tyz,tyz->", plane, plane, dtype=np.float64))
                        sums[c][1] += plane.size
        # clipping of any embedding is recorded with the field, never only printed (issue 4)
        w.add_attrs(synthesis_report=gen.report)
        path = w.path
    summary = {"path": str(path), "seconds": time.perf_counter() - t0, "spilled": spill}
    for c in COMPONENTS:
        summary[f"sigma_{c}"] = math.sqrt(sums[c][0] / sums[c][1])
    summary["expected_sigma"] = [math.sqrt(gen.expected_variance(c)) for c in COMPONENTS]
    summary.update(gen.report)
    return summary
