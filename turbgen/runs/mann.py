"""One Mann space-time run: parameters + grid + seed -> stencil -> snapshots -> zarr store.

    run = MannRun.from_mapping({"length_scale_m": 49, "gamma": 3.1, "evo_time_s": 400})
    summary = run_mann(run, "mann.zarr", progress=True)

Used by ``turbgen mann`` and by the sweep, so both give bit-identical stores. The stencil
(build_mann_stencil) depends on everything but the seed and can be shared between seeds.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from turbgen.errors import ParameterError, check_choice
from turbgen.grid import Grid
from turbgen.resources import format_bytes, require_memory
from turbgen.runs.defaults import MANN_DEFAULTS, MANN_GRID
from turbgen.runs.naming import run_digest
from turbgen.runs.stencil_cache import cached_stencil
from turbgen.store import create_store
from turbgen.synthesis.mann_spacetime import COMPONENTS, MannSnapshots, snapshot_memory_bytes
from turbgen.synthesis.mann_stencil import (
    BoxShape,
    MannStencil,
    UnitMannStencil,
    build_stencil,
    scale_stencil,
    stencil_nbytes,
)
from turbgen.theory import ranges
from turbgen.theory.kaimal import IEC_IREF, iec_sigma1_m_s
from turbgen.theory.params import MannParams, check_wind_speed

_UNITS = {
    "ae": "m4/3 s-2", "length_scale_m": "m", "gamma": "1", "lifetime": "", "factor1": "1", "factor2": "1",
    "evo_time_s": "s", "U_m_s": "m s-1", "seed": "1", "hub_height_m": "m", "pad_yz": "1", "ae_from": "",
}  # fmt: skip
_INPUT_KEYS = set(_UNITS) | {"sigma_u_m_s", "ti", "turb_class", "grid"}
_BUILD_SCRATCH = 64 * 2**20  # float64 temporaries of the stencil-building batches (all threads)


@dataclass(frozen=True)
class MannRun:
    """Everything that determines a Mann space-time field (paper 000 Sect. 2.3.1).

    params : Mann parameters (ae, L, Gamma, lifetimes, evolution time gamma [s]).
    grid : planes x_m [m upstream], nt samples dt_s [s] apart (dx = U dt), ny x nz points dy_m, dz_m [m].
    U_m_s : mean wind speed [m/s]; seed : random seed (>= 0); hub_height_m : metadata [m].
    pad_yz : the synthesis box is pad_yz times wider in y and z than the output (cropped).
    ae_from : how ae was chosen (text, recorded in the store).
    """

    params: MannParams
    grid: Grid
    U_m_s: float
    seed: int
    hub_height_m: float = 150.0
    pad_yz: int = 2
    ae_from: str = "ae"

    def __post_init__(self):
        object.__setattr__(self, "U_m_s", check_wind_speed(self.U_m_s))
        for key in ("seed", "hub_height_m", "pad_yz"):  # ranges: turbgen.theory.ranges
            object.__setattr__(self, key, ranges.check(key, getattr(self, key)))
        ranges.check_grid(self.grid)

    @property
    def box(self) -> BoxShape:
        """The periodic synthesis box: (nt, dx = U dt) x (pad ny, dy) x (pad nz, dz)."""
        g = self.grid
        return BoxShape(g.nt, self.U_m_s * g.dt_s, self.pad_yz * g.ny, self.pad_yz * g.nz, g.dy_m, g.dz_m)

    def plane_times_s(self) -> np.ndarray:
        """Relative snapshot time t_n = x_n / U [s] of each plane, in storage order."""
        return self.grid.x() / self.U_m_s

    def parameters(self) -> dict:
        """The input parameters (keys of the run mapping, see schemas/mann-run.schema.json)."""
        p = self.params
        return {
            "ae": p.ae, "length_scale_m": p.length_scale_m, "gamma": p.gamma, "lifetime": p.lifetime,
            "factor1": p.factor1, "factor2": p.factor2, "evo_time_s": p.evo_time_s, "U_m_s": self.U_m_s,
            "seed": self.seed, "hub_height_m": self.hub_height_m, "pad_yz": self.pad_yz, "ae_from": self.ae_from,
        }  # fmt: skip

    def to_attrs(self) -> dict:
        """model / parameters / units / seed / U_m_s / hub_height_m attributes of the store."""
        params = self.parameters()
        return {
            "model": "mann",
            "parameters": params,
            "units": {k: _UNITS[k] for k in params},
            "seed": self.seed,
            "U_m_s": self.U_m_s,
            "hub_height_m": self.hub_height_m,
        }

    def default_store_name(self) -> str:
        """A readable store name from the parameters, e.g. mann_U16_L49_G3.1_evo400_s1.zarr.

        Runs that differ from the named ones only in parameters the name does not show (lifetime,
        factor1/2, energy level, grid, pad-yz, hub height) get ``_p<8 hex digits>`` of everything
        that determines the field appended, so two different fields never share a default name.
        """
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
        """A run from a (validated) mapping with the schema keys; missing keys take runs.defaults.

        The energy level: ``ae`` if given, else the ae giving the model sigma_u = ``sigma_u_m_s``,
        else ``ti`` * U, else the IEC NTM sigma_1 of ``turb_class`` (default A) at U.
        """
        unknown = set(d) - _INPUT_KEYS
        if unknown:
            raise ParameterError(f"mann config: unknown keys {sorted(unknown)}")
        v = {**MANN_DEFAULTS, **{k: val for k, val in d.items() if k != "grid"}}
        g = {**MANN_GRID, **d.get("grid", {})}
        if "dz_m" not in d.get("grid", {}) and "dy_m" in d.get("grid", {}):
            g["dz_m"] = g["dy_m"]
        grid = Grid(g["nt"], g["dt_s"], tuple(g["x_m"]), g["ny"], g["nz"], g["dy_m"], g["dz_m"])
        U = check_wind_speed(v["U_m_s"])
        ranges.check_grid(grid)  # the cheap checks before the energy-level quadrature of _resolve_ae
        for key in ("seed", "hub_height_m", "pad_yz"):
            ranges.check(key, v[key])
        shape = MannParams(
            ae=1.0, length_scale_m=v["length_scale_m"], gamma=v["gamma"], lifetime=v["lifetime"],
            factor1=v["factor1"], factor2=v["factor2"], evo_time_s=v["evo_time_s"],
        )  # fmt: skip
        ae, ae_from = _resolve_ae(d, shape, U, v["turb_class"])
        return cls(shape.with_ae(ae), grid, U, v["seed"], v["hub_height_m"], v["pad_yz"], ae_from)


def _resolve_ae(d: Mapping, shape: MannParams, U: float, turb_class: str) -> tuple[float, str]:
    if d.get("ae") is not None:
        return ranges.check("ae", d["ae"]), d.get("ae_from", "ae")
    if d.get("sigma_u_m_s") is not None:
        sigma = ranges.check("sigma_u_m_s", d["sigma_u_m_s"])
        how = f"sigma_u = {sigma:g} m/s"
    elif d.get("ti") is not None:
        ti = ranges.check("ti", d["ti"])
        sigma, how = ti * U, f"ti = {ti:g} (sigma_u = {ti * U:g} m/s)"
    else:
        check_choice("turb_class", turb_class, tuple(IEC_IREF))
        sigma = iec_sigma1_m_s(U, turb_class)
        how = f"IEC class {turb_class} NTM sigma_1 = {sigma:.4g} m/s at U"
    from turbgen.theory.mann_spectra import ae_for_sigma_u  # model variance, paper 000 Eq. 8 integrated

    return ae_for_sigma_u(sigma, shape), f"model sigma_u: {how}"


def mann_preset_keys(preset: str, presets_file: str | Path | None = None) -> dict:
    """Run-mapping keys a stability preset sets: length_scale_m, gamma, evo_time_s, factor1, lifetime, turb_class.

    ae then follows U (IEC sigma_1 of the preset's class). The same keys as the sweep uses
    (turbgen.presets.mann_run_keys), so `turbgen mann --preset` and the sweep build the same run.
    """
    from turbgen.presets import load_presets, mann_run_keys

    return mann_run_keys(preset, user=load_presets(presets_file) if presets_file else None)


def build_mann_stencil(run: MannRun, cache_dir: str | Path | None = None) -> MannStencil:
    """The per-parameter-set part of a run (the same for runs differing only in seed)."""
    if cache_dir is None:
        return build_stencil(run.params, run.box, evolving=run.grid.nx > 1)
    return cached_stencil(run.params, run.box, cache_dir, evolving=run.grid.nx > 1)


def memory_estimate_bytes(run: MannRun, threads: int, with_stencil: bool = True) -> int:
    """Bytes a run allocates: stencil (unless given), OU state, spectra, one output plane, store buffers."""
    g = run.grid
    evolving = run.params.evo_time_s is not None and g.nx > 1
    need = snapshot_memory_bytes(run.box, g.ny, g.nz, g.nx if evolving else 1, threads, buffers=2)
    need += 2 * g.nt * g.ny * g.nz * 4  # the output plane and the store's encoding buffers
    if with_stencil:
        need += stencil_nbytes(run.box, evolving) + _BUILD_SCRATCH
    return need


def describe(run: MannRun, out: str | Path, threads: int, with_stencil: bool = True) -> list[str]:
    """Lines saying what a run will generate (grid, synthesis box, memory, output path)."""
    g, b, p = run.grid, run.box, run.params
    evo = "frozen" if p.evo_time_s is None else f"gamma = {p.evo_time_s:g} s"
    return [
        f"Mann space-time field: L = {p.length_scale_m:g} m, Gamma = {p.gamma:g}, {evo}, lifetime {p.lifetime}, "
        f"ae = {p.ae:.4g} m^(4/3)/s^2 ({run.ae_from}), U = {run.U_m_s:g} m/s, seed {run.seed}",
        f"grid: {g.nt} x {g.nx} x {g.ny} x {g.nz} (t, x, y, z), dt = {g.dt_s:g} s (dx = {b.dx_m:g} m), "
        f"dy = {g.dy_m:g} m, dz = {g.dz_m:g} m, planes x = {', '.join(f'{x:g}' for x in g.x_m)} m",
        f"synthesis box: {b.nt} x {b.nyp} x {b.nzp} (pad-yz {run.pad_yz}), "
        f"{b.nt * b.dx_m:g} x {b.nyp * b.dy_m:g} x {b.nzp * b.dz_m:g} m",
        f"memory: about {format_bytes(memory_estimate_bytes(run, threads, with_stencil))} in one pass; "
        f"output: {out} ({format_bytes(3 * g.nbytes_per_component())} float32 before compression)",
    ]


def run_mann(
    run: MannRun,
    out: str | Path,
    *,
    overwrite: bool = False,
    chunk_t: int | None = None,
    progress: bool = False,
    stencil: MannStencil | UnitMannStencil | None = None,
    threads: int | None = None,
    cache_dir: str | Path | None = None,
) -> dict:
    """Generate ``run`` into a new store at ``out``; return {path, sigma_u/v/w [m/s], seconds, ...}.

    Memory is checked before anything is allocated; planes are written as they are produced;
    an exception (or Ctrl-C) leaves no store at ``out``. ``stencil`` (from build_mann_stencil of a
    run with the same parameters and grid) skips the stencil computation, a UnitMannStencil (of a run
    differing at most in ae and seed) leaves only its scaling to ae. ``threads`` defaults
    to os.cpu_count() and does not change the field.
    """
    t_start = time.perf_counter()
    gen_threads = MannSnapshots.default_threads(threads)
    unit, stencil = (stencil, None) if isinstance(stencil, UnitMannStencil) else (None, stencil)
    if unit is not None and (unit.params != run.params.with_ae(1.0) or unit.box != run.box):
        raise ParameterError("the given unit stencil was built for other parameters or another grid than this run")
    if unit is not None and unit.inv_tau is None and run.params.evo_time_s is not None and run.grid.nx > 1:
        raise ParameterError("the given stencil was built for one plane (evolving=False); this run evolves planes")
    if stencil is not None and (stencil.params != run.params or stencil.box != run.box):
        raise ParameterError("the given stencil was built for other parameters or another grid than this run")
    if stencil is not None and stencil.inv_tau is None and run.params.evo_time_s is not None and run.grid.nx > 1:
        raise ParameterError("the given stencil was built for one plane (evolving=False); this run evolves planes")
    g = run.grid
    require_memory(
        memory_estimate_bytes(run, gen_threads, with_stencil=stencil is None),
        f"the Mann run ({g.nt} x {g.ny} x {g.nz}, synthesis box {run.box.nt} x {run.box.nyp} x {run.box.nzp})",
        "lower --nt, --ny/--nz or --pad-yz",
    )
    path = Path(out)
    sums = {c: [0.0, 0.0] for c in COMPONENTS}
    with create_store(path, g, run.to_attrs(), chunk_t=chunk_t, overwrite=overwrite) as writer:
        if unit is not None:
            stencil = scale_stencil(unit, run.params)
        elif stencil is None:
            stencil = build_mann_stencil(run, cache_dir)
        gen = MannSnapshots(stencil, g.ny, g.nz, gen_threads, buffers=2)
        show = progress and sys.stderr.isatty()
        bar = tqdm(total=g.nx, unit="plane", desc="mann", file=sys.stderr, disable=not show)
        # One write in flight while the generator computes the next item (it alternates two buffers);
        # leaving the pool waits for that write, so an exception never races the store's clean-up.
        with bar, ThreadPoolExecutor(1) as background:
            pending = None

            def write_and_sum(comp, ix, field):  # in the background, with the next item's synthesis
                writer.write(comp, ix, field)
                flat = field.reshape(-1)
                sums[comp][0] += float(flat.sum(dtype=np.float64))
                sums[comp][1] += float(np.dot(flat, flat))

            for done, (ix, comp, field) in enumerate(gen.generate(run.seed, run.plane_times_s()), start=1):
                if pending is not None:
                    pending.result()
                pending = background.submit(write_and_sum, comp, ix, field)
                if done % 3 == 0:
                    bar.update(1)
            if pending is not None:
                pending.result()
    n = g.nt * g.nx * g.ny * g.nz
    summary = {"path": str(path), "seconds": time.perf_counter() - t_start}
    for c, (s1, s2) in sums.items():
        mean = s1 / n
        summary[f"sigma_{c}"] = math.sqrt(max(s2 / n - mean * mean, 0.0))
        summary[f"mean_{c}"] = mean
    return summary

