"""A sweep definition: models x presets x speeds x seeds on one grid, from a TOML/JSON file
(``turbgen/schemas/sweep.schema.json``) or options. Each run is built as ``turbgen mann|kaimal --preset P --U U --seed S``
builds it (the same field); stores are named ``{model}_{preset}_U{U:g}_seed{seed}.zarr``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from turbgen.errors import ParameterError, check_int
from turbgen.runs.models import MODELS, get_model
from turbgen.spec.config import load_schema
from turbgen.spec.constraints import ConstraintRequest
from turbgen.spec.models import declaration
from turbgen.spec.presets import StabilityPreset, get_preset
from turbgen.spec.preset_runs import run_keys
from turbgen.spec.user_spectrum import read_spectrum_csv
from turbgen.store.paths import check_output_dir
from turbgen.sweep.scheduler import check_scheduler_address
from turbgen.theory import ranges
from turbgen.theory.params import check_wind_speed

GRID_KEYS = ("nt", "dt", "planes", "ny", "nz", "dy", "dz", "hub_height")
# sweep grid option -> key of the run mapping's grid table (missing ones: the model's defaults, turbgen.spec.defaults)
_GRID_NAMES = {"nt": "nt", "dt": "dt_s", "planes": "x_m", "ny": "ny", "nz": "nz", "dy": "dy_m", "dz": "dz_m"}


def build_run(model: str, preset: str | StabilityPreset, U_m_s: float, seed: int, grid: Mapping | None = None,
              *, user: Mapping[str, StabilityPreset] | None = None, spectrum=None):
    """The MannRun / KaimalRun of one preset run, exactly as ``turbgen mann|kaimal --preset`` builds it.

    ``preset`` a name (built-in or in ``user``) or a StabilityPreset; ``U_m_s`` [m/s]; ``grid``: the sweep schema's
    grid options (nt, dt [s], planes [m], ny, nz, dy [m], dz [m], hub_height [m]; missing: the model's defaults);
    ``spectrum``: ``turbgen kaimal --spectrum``'s table. ParameterError for an unknown model or preset or a bad value.
    """
    spec = get_model(model).spec
    mapping = {"U_m_s": U_m_s, "seed": seed, **grid_mapping(grid)}
    if spectrum is not None:
        mapping["spectrum"] = spectrum
    return spec.from_mapping({**run_keys(model, preset, U_m_s, user=user), **mapping})


def grid_mapping(grid: Mapping | None) -> dict:
    """The run-mapping keys of sweep grid options: ``{"grid": {nt, dt_s, x_m, ...}}`` (+ ``hub_height_m``)."""
    opts = dict(grid or {})
    g = {key: opts[name] for name, key in _GRID_NAMES.items() if name in opts}
    if "x_m" in g:
        g["x_m"] = [float(x) for x in g["x_m"]]
    return {"grid": g, **({"hub_height_m": opts["hub_height"]} if "hub_height" in opts else {})}


def store_name(model: str, preset: str, U_m_s: float, seed: int) -> str:
    """Readable, stable store name of one run: ``mann_neutral_U16_seed2.zarr`` (U written with ``:g``)."""
    return f"{model}_{preset}_U{U_m_s:g}_seed{seed}.zarr"


@dataclass(frozen=True)
class PlannedRun:
    """One field of the sweep: model, preset, U [m/s], seed, the run (MannRun or KaimalRun) and its store name."""

    model: str
    preset: str
    U_m_s: float
    seed: int
    run: object
    constraint_tag: str = ""  # constrained runs: "c" + the digest of the data on the run's grid (+ "mean")

    @property
    def store_name(self) -> str:
        """The run's store name (:func:`store_name`, with ``_<constraint_tag>`` for a constrained run)."""
        name = store_name(self.model, self.preset, self.U_m_s, self.seed)
        return name if not self.constraint_tag else f"{name.removesuffix('.zarr')}_{self.constraint_tag}.zarr"

    @property
    def name(self) -> str:
        """The run's name in the manifest: its store name without ``.zarr``."""
        return self.store_name.removesuffix(".zarr")


@dataclass(frozen=True)
class SweepPlan:
    """Validated sweep definition (:func:`make_plan`'s arguments) and its runs, models x presets x speeds x seeds."""

    out: Path
    models: tuple[str, ...]
    presets: tuple[str, ...]
    speeds_m_s: tuple[float, ...]
    seeds: tuple[int, ...]
    grid: Mapping = field(default_factory=dict)  # common grid options (schema names)
    model_grid: Mapping = field(default_factory=dict)  # model -> grid options overriding `grid`
    validate: bool = False
    chunk_t: int | None = None
    workers: int | None = None
    scheduler: str | None = None
    user_presets: Mapping[str, StabilityPreset] = field(default_factory=dict)
    runs: tuple[PlannedRun, ...] = ()
    lidar: str | None = None  # lidar preset or file run on every field (turbgen lidar)
    constraints: ConstraintRequest | None = None  # every run conditioned on the same files (Mann only)
    spectrum: str | None = None  # user spectra CSV of the runs of models that take one (Kaimal)

    def to_dict(self) -> dict:
        """The definition, JSON-ready, for the manifest."""
        return {
            "models": list(self.models),
            "presets": list(self.presets),
            "speeds": list(self.speeds_m_s),
            "seeds": list(self.seeds),
            "grid": dict(self.grid),
            **{m: dict(g) for m, g in self.model_grid.items()},
            "validate": self.validate,
            "lidar": self.lidar,
            "chunks": self.chunk_t,
            "user_presets": sorted(self.user_presets),
            "n_runs": len(self.runs),
            **({} if self.spectrum is None else {"spectrum": self.spectrum}),
            **({} if self.constraints is None else {"constraints": {
                "constrain": [str(f) for f in self.constraints.files], "noise_m_s": self.constraints.noise_m_s,
                "conditional_mean": self.constraints.conditional_mean}}),
        }  # fmt: skip


def _unique(name: str, values) -> tuple:
    values = tuple(values)
    if not values:
        raise ParameterError(f"{name}: at least one value is needed")
    if len(set(values)) != len(values):
        raise ParameterError(f"{name} = {list(values)} contain a duplicate")
    return values


def check_grid_keys(where: str, opts: Mapping | None) -> dict:
    """A copy of the grid options ``opts`` (None: empty); ParameterError naming ``where`` for keys outside GRID_KEYS."""
    opts = dict(opts or {})
    unknown = sorted(set(opts) - set(GRID_KEYS))
    if unknown:
        raise ParameterError(f"{where}: unknown grid option(s) {', '.join(unknown)}; allowed: {', '.join(GRID_KEYS)}")
    return opts


def make_plan(*, out: str | Path, models, presets, speeds, seeds, grid: Mapping | None = None,
              model_grid: Mapping[str, Mapping] | None = None, validate: bool = False, chunk_t: int | None = None,
              workers: int | None = None, scheduler: str | None = None,
              user_presets: Mapping[str, StabilityPreset] | None = None, lidar: str | None = None,
              constraints: ConstraintRequest | None = None, spectrum: str | Path | None = None,
) -> SweepPlan:  # fmt: skip
    """Check a sweep definition and build all its runs (ParameterError on the first bad value).

    ``models``, ``presets``, ``speeds`` [m/s], ``seeds``: each non-empty, without duplicates, within
    turbgen.theory.ranges.LIMITS. ``grid``: common grid options (:func:`build_run`), ``model_grid``: per model
    overrides. ``workers``: LocalCluster workers, excluding ``scheduler`` (tcp://HOST:PORT). ``lidar``: preset or file
    run on every field. ``constraints``: a ConstraintRequest conditioning every (Mann) run (store names get the data's
    digest). Also refused: an unreachable scheduler, an unusable ``out``, duplicate store names and, without a
    scheduler, a run needing more memory than is available here."""
    user = dict(user_presets or {})
    models, presets = _check_models_presets(models, presets, user)
    speeds, seeds = list(speeds), list(seeds)
    ranges.check_count("speeds", len(speeds))
    ranges.check_count("seeds", len(seeds))
    ranges.check_count("runs", len(models) * len(presets) * len(speeds) * len(seeds),
                       "runs (models x presets x speeds x seeds)")  # fmt: skip
    speeds = _unique("speeds", (check_wind_speed(u) for u in speeds))
    seeds = _unique("seeds", (ranges.check("seed", s) for s in seeds))
    grid = check_grid_keys("grid", grid)
    model_grid = {m: check_grid_keys(m, g) for m, g in (model_grid or {}).items() if g}
    for m in model_grid:
        if m not in MODELS:
            raise ParameterError(f"grid table {m!r} is not one of {', '.join(MODELS)}")
    chunk_t, workers, lidar_description = _check_execution(out, chunk_t, workers, scheduler, lidar)
    table = None if spectrum is None else read_spectrum_csv(spectrum)
    runs = _planned_runs(models, presets, speeds, seeds, lambda m: {**grid, **model_grid.get(m, {})}, user, table)
    if constraints is not None:
        runs = _constrained_runs(runs, constraints)
    _check_runs(runs, speeds, chunk_t, lidar_description, local=not scheduler)
    return SweepPlan(Path(out), models, presets, speeds, seeds, grid, model_grid, bool(validate), chunk_t, workers,
                     scheduler or None, user, runs=tuple(runs),
                     lidar=None if lidar is None else str(lidar), constraints=constraints,
                     spectrum=None if spectrum is None else str(spectrum))  # fmt: skip


def _constrained_runs(runs: list[PlannedRun], constraints: ConstraintRequest) -> list[PlannedRun]:
    """``runs`` with their constraint tags: the data placed on each run's grid (checked), digested with the noise."""
    from turbgen.runs.constrain import constrained_store_name, load_constraints, place

    others = sorted({r.model for r in runs} - {"mann"})
    if others:
        raise ParameterError(f"constrain: the sweep conditions Mann runs only (models also has {', '.join(others)})")
    loaded = load_constraints(constraints.files)
    tags: dict = {}
    out = []
    for r in runs:
        key = replace(r.run, seed=0)  # the seed does not move the data
        if key not in tags:
            name = constrained_store_name(r.run, place(r.run, loaded, constraints.noise_m_s),
                                          constraints.conditional_mean)  # fmt: skip
            tags[key] = name.removesuffix(".zarr").rpartition("_")[2]
        out.append(replace(r, constraint_tag=tags[key]))
    return out


def _check_models_presets(models, presets, user) -> tuple[tuple, tuple]:
    """(models, presets) without duplicates, each model and preset known."""
    models = _unique("models", models)
    for m in models:
        if m not in MODELS:
            raise ParameterError(f"model = {m!r} is not one of {', '.join(MODELS)}")
    presets = _unique("presets", presets)
    for p in presets:
        get_preset(p, user)  # one without a model's parameters: that model's preset keys refuse it (build_run)
    return models, presets


def _check_execution(out, chunk_t, workers, scheduler, lidar):
    """(chunk_t, workers, lidar description or None) checked, with ``out`` and ``scheduler`` (ParameterError)."""
    if chunk_t is not None:
        chunk_t = check_int("chunks", chunk_t, 1)
    if workers is not None:
        workers = check_int("workers", workers, 1, ranges.LIMITS["workers"])
    if workers is not None and scheduler:
        raise ParameterError("workers and scheduler exclude each other (the scheduler's cluster has its own workers)")
    if scheduler:
        check_scheduler_address(scheduler)
    check_output_dir(out, "out (sweep directory)")
    description = None
    if lidar is not None:
        from turbgen.virtual_lidar.description import load_lidar

        description = load_lidar(lidar)  # a bad preset or file fails here, before any run
    return chunk_t, workers, description


def _planned_runs(models, presets, speeds, seeds, grid_options, user, table=None) -> list[PlannedRun]:
    """Every run in nested order models x presets x speeds x seeds (``grid_options(model)``; ``table``: a user
    spectrum for the models that take one)."""
    runs = []
    for m in models:
        opts = grid_options(m)
        takes = table is not None and "spectrum" in load_schema(declaration(m).schema)["properties"]
        spectrum = (table[0], *table[1]) if takes else None
        for p in presets:
            for U in speeds:
                # the seed changes nothing but the random streams: build the run once, then swap the seed
                first = build_run(m, p, U, seeds[0], opts, user=user, spectrum=spectrum)
                for s in seeds:
                    runs.append(PlannedRun(m, p, U, s, first if s == seeds[0] else replace(first, seed=s)))
    return runs


def _check_runs(runs, speeds, chunk_t, lidar_description, *, local: bool) -> None:
    """Checks of the planned runs together: chunk length, lidar fit, distinct names, memory here (``local``)."""
    if chunk_t is not None:  # the store writer's check, before any run instead of in every run
        for nt in sorted({r.run.grid.nt for r in runs}):
            check_int("chunks (time samples per chunk)", chunk_t, 1, nt)
    if lidar_description is not None:  # gates on planes, beams inside the field: refused before any field is made
        from turbgen.virtual_lidar.run import check_lidar_fits

        for g in {r.run.grid for r in runs}:
            check_lidar_fits(lidar_description, g)
    names = [r.name for r in runs]
    if len(set(names)) != len(names):
        raise ParameterError(f"speeds = {list(speeds)} give duplicate store names (they differ below 6 digits)")
    if local:  # a remote cluster's workers have their own memory (and check it themselves)
        check_plan_memory(runs)


def _distinct(runs):
    """The runs, the first of those differing only in seed (which changes no memory)."""
    seen = set()
    for pr in runs:
        if (key := replace(pr.run, seed=0)) not in seen:
            seen.add(key)
            yield pr


def check_memory_budget(runs, memory_bytes: int | None, chunk_t: int | None = None) -> None:
    """Refuse a per-run budget ``memory_bytes`` (`turbgen sweep --memory`; None: no check) that a planned
    Mann run cannot be made within even out of core."""
    if memory_bytes is None:
        return
    from turbgen.resources import format_bytes
    from turbgen.runs.mann_outofcore import least_budget_bytes

    for pr in (r for r in _distinct(runs) if MODELS[r.model].out_of_core):
        need = least_budget_bytes(pr.run, chunk_t)
        if memory_bytes < need:
            raise ParameterError(
                f"run {pr.name} cannot be made within a memory budget of {format_bytes(memory_bytes)}: it needs at "
                f"least {format_bytes(need)} even out of core; raise `memory_bytes`, or lower `nt`, `ny`/`nz` or `pad_yz`"
            )


def check_plan_memory(runs) -> None:
    """Refuse the sweep when a run's smallest footprint exceeds the memory available here."""
    from turbgen.resources import available_memory_bytes, format_bytes

    available = available_memory_bytes()
    if available is None:
        return
    for pr in _distinct(runs):
        model = MODELS[pr.model]
        need = model.least_memory_bytes(pr.run)
        if need > available:
            g = pr.run.grid
            raise ParameterError(
                f"run {pr.name} ({g.nt} x {g.nx} x {g.ny} x {g.nz}) needs about {format_bytes(need)} of memory but only "
                f"{format_bytes(available)} is available; lower {model.memory_fields}"
            )
