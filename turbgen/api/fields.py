"""``turbgen.mann``, ``turbgen.kaimal`` and ``turbgen.open_store``: fields as xarray Datasets, built by the commands'
rule (run file < preset < keywords) and made by the same functions (turbgen.runs): the same field to the bit."""

from __future__ import annotations

import os
import tempfile
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from turbgen import fft
from turbgen.errors import ParameterError, check_int
from turbgen.resources import available_memory_bytes, default_threads, parse_size, require_memory
from turbgen.spec.constraints import ConstraintRequest
from turbgen.spec.kaimal import KaimalRun
from turbgen.spec.mann import MannRun
from turbgen.spec.run_mapping import PathLike, kaimal_run, mann_run_mapping
from turbgen.store import open_store as _open_field_store
from turbgen.store.paths import check_output_path
from turbgen.store.writer import check_new_store

if TYPE_CHECKING:  # annotations only (see _as_dataset)
    import xarray as xr


def _as_dataset(path: Path) -> xr.Dataset:
    """The checked store at ``path`` as a lazy Dataset whose ``encoding["source"]`` is the store's path."""
    import xarray as xr  # on use: the commands write stores and need no Dataset (xarray + pandas are slow to import)

    fs = _open_field_store(path)
    ds = xr.open_zarr(str(fs.path), consolidated=True)
    ds.encoding["source"] = str(fs.path)
    return ds


def _through_store(make, grid, name: str) -> xr.Dataset:
    """Run ``make(path)`` into a temporary store and return its field loaded into memory (a field without ``out``
    whose run does not fit in memory together with the field)."""
    require_memory(3 * grid.nbytes_per_component(), f"the field in memory ({name})",
                   "pass `out` to write a store instead, or lower `nt`, `ny`/`nz` or the number of planes")
    with tempfile.TemporaryDirectory(prefix="turbgen-") as tmp:
        path = Path(tmp) / name
        make(path)
        with _as_dataset(path) as ds:
            loaded = ds.load()
    loaded.encoding.pop("source", None)
    return loaded


def open_store(path: PathLike) -> xr.Dataset:
    """Open a turbgen field store as a lazy ``xarray.Dataset``, after checking it.

    Parameters
    ----------
    path : str or os.PathLike
        The store directory (e.g. ``mann_U16_L49_G3.1_evo400_s1.zarr``).

    Returns
    -------
    xarray.Dataset
        u, v, w (t, x, y, z) [m/s] with coordinates t [s], x, y, z [m] and the store's attributes; lazy (dask).
        ``encoding["source"]`` holds the store's path, so the Dataset can be given to :func:`turbgen.validate`,
        :func:`turbgen.export` and :func:`turbgen.lidar`.

    Raises
    ------
    StoreError
        If ``path`` is not a complete, valid turbgen store (missing, partial, corrupted).

    Examples
    --------
    >>> import tempfile, turbgen
    >>> out = tempfile.mkdtemp() + "/box.zarr"
    >>> _ = turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 50], out=out)
    >>> ds = turbgen.open_store(out)
    >>> dict(ds.sizes)
    {'t': 64, 'x': 2, 'y': 4, 'z': 4}
    """
    return _as_dataset(Path(path))


@fft.selected_by_keyword
def mann(L: float | None = None, gamma: float | None = None, evo: float | str | None = None,
         seed: int | None = None, out: PathLike | None = None, *, U: float | None = None, ae: float | None = None,
         sigma_u: float | None = None, ti: float | None = None, planes: Sequence[float] | float | None = None,
         gates: Sequence[float] | str | None = None, nt: int | None = None, dt: float | None = None,
         ny: int | None = None, nz: int | None = None, dy: float | None = None, dz: float | None = None,
         lifetime: str | None = None, factor1: float | None = None, factor2: float | None = None,
         pad_yz: int | None = None, hub_height: float | None = None, preset: str | None = None,
         presets_file: PathLike | None = None, config: PathLike | Mapping | None = None, overwrite: bool = False,
         chunks: int | None = None, threads: int | None = None, stencil_cache: PathLike | None = None,
         memory: int | str | None = None, constrain: Sequence | None = None, noise: float | None = None,
         conditional_mean: bool = False, fit: bool = False, progress: bool = False,
         fft_backend: str | None = None) -> xr.Dataset:  # fmt: skip
    """A Mann space-time 4D field u(t, x, y, z) (Mann 1994; Guo et al. 2022): the field of ``turbgen mann``.

    The keywords are the options of ``turbgen mann`` with their names, meanings and defaults (docs/cli.md); run-file
    keys (e.g. ``length_scale_m``) go in ``config``. A keyword left at None takes the run file's value, else the
    preset's, else the default (turbgen/spec/defaults.py). :class:`turbgen.MannGenerator` makes further seeds without
    building the stencil again.

    Parameters
    ----------
    L : float, optional
        Length scale L [m].
    gamma : float, optional
        Shear anisotropy Γ [-].
    evo : float or str, optional
        Eddy evolution time γ [s], or ``"frozen"``.
    seed : int, optional
        Random seed (>= 0).
    U : float, optional
        Mean wind speed [m/s].
    ae, sigma_u, ti : float, optional
        One energy level: αε^(2/3) [m^(4/3) s^-2], the model σ_u [m/s] or σ_u / U [-] (default: IEC class A σ_1).
    planes : sequence of float, optional
        Plane positions x [m upstream].
    gates : sequence of float or str, optional
        Range gates [m] (``"start:stop:step"``); planes = rotor 0 + gates.
    nt, ny, nz : int, optional
        Time samples, lateral and vertical points.
    dt, dy, dz : float, optional
        Time step [s] (dx = U dt), lateral and vertical spacing [m] (dz default: dy).
    lifetime : {"guo", "mann"}, optional
        Eddy lifetime model.
    factor1, factor2 : float, optional
        Guo lifetime small-k slope and τ_e large-k slope factors [-].
    pad_yz : int, optional
        Synthesis box this many times wider in y and z, cropped.
    hub_height : float, optional
        Hub height [m].
    out : str or os.PathLike, optional
        Store to write. None: the field in memory (no file left; through a temporary store when the run and the
        field do not fit ``memory``): the same values either way.
    config : str, os.PathLike or Mapping, optional
        A run file (TOML/JSON) or a mapping of its keys.
    preset, presets_file : optional
        Stability preset (``unstable``, ``neutral``, ``stable`` or one of ``presets_file``, TOML/JSON).
    overwrite : bool, optional
        Replace an existing store at ``out``.
    chunks, threads : int, optional
        Time samples per store chunk, worker threads (default: all cores); neither changes the field.
    stencil_cache : str or os.PathLike, optional
        Directory keeping the stencil (and with ``constrain`` the measurement system) for later seeds.
    memory : int or str, optional
        Memory budget [bytes] or a size such as ``"4GiB"`` (default: the available memory); a field over it is made
        out of core, the same field.
    constrain : list, optional
        Condition the field on measurements (Hoffman & Ribak 1991): constraint files (point series JSON or CSV,
        ``turbgen lidar --out`` datasets) or loaded constraints; made in memory in one pass. Without an energy level
        (``ae``, ``sigma_u``, ``ti``, a class) ae is estimated from the data (``attrs["derived"]["ae_from"]``).
    noise : float, optional
        With ``constrain``: measurement-noise σ [m/s] >= 0 of every value (default: each file's, else 0).
    conditional_mean : bool, optional
        With ``constrain``: the conditional mean (no random part).
    fit : bool, optional
        With ``constrain`` of point-series files or one lidar record: fit ae, L, Γ (held for a lidar record), the
        evolution time (sensors along x) and the mean wind to it first (turbgen.runs.replay; ``L``, ``gamma`` and the
        energy level are refused); ``attrs["fit"]`` records it. A run file's ``fit = true`` is the same.
    progress : bool, optional
        Show a progress bar on stderr.
    fft_backend : str, optional
        FFT backend (``"pyfftw"``, ``"scipy"`` or registered; default: TURBGEN_FFT_BACKEND, else pyfftw); changes the
        field at float32 round-off only.

    Returns
    -------
    xarray.Dataset
        u, v, w (t, x, y, z) [m/s], coordinates t [s], x, y, z [m] and the store's attributes; in memory without
        ``out``, else the written store opened lazily. A constrained field has the attribute ``constraints``.

    Raises
    ------
    ParameterError
        For an unknown keyword, a value outside its range, two energy levels, a field that fits neither memory nor
        disk, constraint data that do not match their format or the field, ``noise`` without ``constrain``.
    StoreError
        For an existing ``out`` without ``overwrite``, or an ``out`` that is not a turbgen store with it.

    Warns
    -----
    UserWarning
        When total-wind ``constrain`` data still blow more than 5 deg from the field's x after their mean wind (the
        command's note): the mean of v then enters the field as turbulence.

    Examples
    --------
    >>> import turbgen
    >>> ds = turbgen.mann(L=30, gamma=3.1, evo=400, nt=64, ny=8, nz=8, dy=8, planes=[0, 40], pad_yz=1)
    >>> dict(ds.sizes)
    {'t': 64, 'x': 2, 'y': 8, 'z': 8}
    >>> ds.attrs["parameters"]["length_scale_m"], ds.attrs["seed"]
    (30.0, 1)

    Conditioned on a hub-height sonic (examples/mast.json), the field follows the data at the measurements:

    >>> from pathlib import Path
    >>> mast = Path(turbgen.__file__).parents[1] / "examples" / "mast.json"
    >>> c = turbgen.mann(U=12, nt=64, ny=8, nz=8, dy=8, planes=[0, 40], pad_yz=1, constrain=[mast])
    >>> record = c.attrs["constraints"]
    >>> record["n_samples"], record["residual_rms_m_s"] < 0.1
    (128, True)
    """
    options = dict(L=L, gamma=gamma, evo=evo, seed=seed, U=U, ae=ae, sigma_u=sigma_u, ti=ti, planes=planes,
                   gates=gates, nt=nt, dt=dt, ny=ny, nz=nz, dy=dy, dz=dz, lifetime=lifetime, factor1=factor1,
                   factor2=factor2, pad_yz=pad_yz, hub_height=hub_height, constrain=constrain, noise=noise,
                   conditional_mean=conditional_mean, fit=fit)  # fmt: skip
    mapping, request = mann_run_mapping(options, config, preset, presets_file)
    if request is None:
        run = MannRun.from_mapping(mapping)
        if out is None and _mann_fits(run, threads, stencil_cache, memory):
            from turbgen.runs.mann import mann_in_memory

            return mann_in_memory(run, progress=progress, threads=default_threads(threads),
                                  cache_dir=None if stencil_cache is None else Path(stencil_cache))[0]
        make = _mann_maker(run, overwrite, chunks, threads, stencil_cache, memory, progress)
    else:
        from turbgen.runs.constrain import mann_constrained_in_memory

        run, files, placed, fit_record = constrained_mann_run(mapping, request, options, stencil_cache, "")
        if out is None and _constrained_fits(run, placed, threads, memory):
            return _noted(mann_constrained_in_memory(run, files, noise_m_s=request.noise_m_s,
                                                     conditional_mean=request.conditional_mean,
                                                     threads=default_threads(threads), cache_dir=stencil_cache,
                                                     progress=progress, placed=placed, fit=fit_record)[0])
        make = _constrained_maker(run, files, request, placed, overwrite, chunks, threads, stencil_cache, fit_record)
    if out is None:
        return _noted(_through_store(make, run.grid, run.default_store_name()))
    make(Path(out))
    return _noted(_as_dataset(Path(out)))


def _noted(ds: xr.Dataset) -> xr.Dataset:
    """``ds``, after a UserWarning for what the command notes of its constraint data (total-wind data off the
    field's x: turbgen.runs.constrain.off_wind_notes)."""
    from turbgen.runs.constrain import off_wind_notes

    for line in off_wind_notes(ds.attrs.get("constraints", {}).get("streams", [])):
        warnings.warn(line.removeprefix("note: "), UserWarning, stacklevel=3)
    return ds


def constrained_mann_run(mapping: dict, request: ConstraintRequest, options: dict, stencil_cache,
                         prefix: str = "--") -> tuple:
    """(run, loaded constraints, placed data, fit record or None) of a constrained ``turbgen.mann`` / ``turbgen
    mann``: with ``request.fit`` fitted to the data first (turbgen.runs.replay; ``options`` given, ``prefix``
    naming them, are refused); without an energy level, ae estimated from the data; every check of the data before
    any output."""
    from turbgen.runs.constrain import load_constraints, place, with_energy_from_data

    constraints, record = load_constraints(request.files), None
    if request.fit:
        from turbgen.runs.replay import check_fit_options, fitted_inputs

        from turbgen.virtual_lidar.dataset import LidarData

        check_fit_options(options, prefix=prefix, lidar=any(isinstance(c, LidarData) for c in constraints))
        mapping, constraints, record = fitted_inputs(mapping, constraints, evo_typed=options.get("evo") is not None)
    run = with_energy_from_data(mapping, constraints, request.noise_m_s, stencil_cache)
    return run, constraints, place(run, constraints, request.noise_m_s), record


def _budget(memory) -> int | None:
    """The memory budget [B]: ``memory`` (bytes or a size such as "4GiB") or the available memory (None: unknown)."""
    if memory is None:
        return available_memory_bytes()
    if isinstance(memory, str):
        return parse_size(memory, "`memory`")
    return check_int("`memory` (bytes)", memory, 1)  # -5 is no budget to raise, but a mistake


def _mann_fits(run: MannRun, threads, stencil_cache, memory) -> bool:
    """Whether ``run`` is made straight into its Dataset: its one-pass arrays, the field and what the process holds
    fit the budget."""
    from turbgen.runs.mann_outofcore import fits_in_memory

    budget = _budget(memory)
    field_bytes = 3 * run.grid.nbytes_per_component()
    return budget is None or fits_in_memory(run, budget - field_bytes, default_threads(threads), stencil_cache is None)


def _constrained_fits(run: MannRun, placed, threads, memory) -> bool:
    """Whether the constrained ``run`` and its field fit the budget in memory."""
    from turbgen.runs.constrain import constrained_memory_bytes

    budget = _budget(memory)
    needed = constrained_memory_bytes(run, placed, default_threads(threads)) + 3 * run.grid.nbytes_per_component()
    return budget is None or needed <= budget


def _mann_maker(run: MannRun, overwrite, chunks, threads, stencil_cache, memory, progress):
    """The function writing ``run`` to a path as ``turbgen mann`` does (out of core when over the budget)."""
    from turbgen.runs.mann import run_mann
    from turbgen.runs.mann_outofcore import plan_for_budget, remove_stale_scratch, run_mann_outofcore

    threads = default_threads(threads)
    budget = _budget(memory)

    def make(out: Path) -> None:
        check_output_path(out, "`out`")
        plan = plan_for_budget(run, budget, threads, chunks, None, stencil_cache is None)
        remove_stale_scratch(out)
        check_new_store(out, run.grid, chunk_t=chunks, overwrite=overwrite,
                        scratch_bytes=0 if plan is None else plan.scratch_bytes())  # fmt: skip
        if plan is not None:
            run_mann_outofcore(run, out, memory_bytes=plan.memory_bytes, overwrite=overwrite, chunk_t=chunks,
                               progress=progress, threads=plan.threads, plan=plan)  # fmt: skip
        else:
            run_mann(run, out, overwrite=overwrite, chunk_t=chunks, progress=progress, threads=threads,
                     cache_dir=stencil_cache)  # fmt: skip

    return make


def _constrained_maker(run: MannRun, constraints, request, placed, overwrite, chunks, threads, stencil_cache, fit):
    """The function writing ``run`` conditioned on the loaded ``constraints`` (``placed`` checked) with ``request``'s
    noise and conditional mean as ``turbgen mann --constrain`` does; ``fit``: the store's fit record."""
    from turbgen.runs.constrain import run_mann_constrained

    def make(out: Path) -> None:
        check_output_path(out, "`out`")
        check_new_store(out, run.grid, chunk_t=chunks, overwrite=overwrite)
        run_mann_constrained(run, out, constraints, noise_m_s=request.noise_m_s,
                             conditional_mean=request.conditional_mean, overwrite=overwrite, chunk_t=chunks,
                             threads=default_threads(threads), cache_dir=stencil_cache, placed=placed,
                             fit=fit)  # fmt: skip

    return make


@fft.selected_by_keyword
def kaimal(U: float | None = None, seed: int | None = None, out: PathLike | None = None, *,
           turb_class: str | None = None, hub_height: float | None = None, sigma: Sequence[float] | None = None,
           lengths: Sequence[float] | None = None, ayz: float | None = None, lc: float | None = None,
           long_model: str | None = None, ax: float | None = None, bx: float | None = None,
           long_components: str | None = None, vw_coherence: str | None = None, rescale: bool = False,
           planes: Sequence[float] | float | None = None, gates: Sequence[float] | str | None = None,
           nt: int | None = None, dt: float | None = None, ny: int | None = None, nz: int | None = None,
           dy: float | None = None, dz: float | None = None, preset: str | None = None,
           presets_file: PathLike | None = None, config: PathLike | Mapping | None = None, overwrite: bool = False,
           chunks: int | None = None, threads: int | None = None, constrain: Sequence | None = None,
           noise: float | None = None, conditional_mean: bool = False, progress: bool = False, spectrum=None,
           coherence=None, fft_backend: str | None = None) -> xr.Dataset:  # fmt: skip
    """A Kaimal 4D field with longitudinal coherence (IEC 61400-1; Guo et al. 2023): the field of ``turbgen kaimal``.

    The keywords are the options of ``turbgen kaimal`` (``turb_class`` is ``--class``), as for :func:`mann`; defaults:
    U 16 m/s, class A, hub 150 m, 4096 × 11 × 31 × 31 at dt 0.5 s, dy = dz 5 m, seed 1.

    Parameters
    ----------
    U : float, optional
        Hub-height mean wind speed [m/s].
    seed : int, optional
        Random seed (>= 0).
    turb_class : {"A+", "A", "B", "C"}, optional
        IEC turbulence class.
    hub_height : float, optional
        Hub height [m].
    sigma, lengths : sequence of three floats, optional
        Explicit σ_u, σ_v, σ_w [m/s] and Kaimal lengths L1, L2, L3 [m].
    ayz, lc : float, optional
        yz coherence decay a_yz [-] and scale Lc [m].
    long_model : {"exp", "simley-pao", "kristensen"}, optional
        Longitudinal coherence model.
    ax, bx : float, optional
        a_x [-] and b_x [1/m] of the exp model.
    long_components : {"u", "uvw"}, optional
        Components given the longitudinal coherence.
    vw_coherence : {"white", "exp"}, optional
        yz coherence of v and w.
    rescale : bool, optional
        Scale the spectra so the expected σ is the nominal one.
    planes, gates, nt, dt, ny, nz, dy, dz : optional
        The grid, as for :func:`mann`.
    out : str or os.PathLike, optional
        Store to write. None: in memory (through a temporary store, spectrum in a scratch file, when the run and the
        field do not fit 80 % of the available memory): the same values either way.
    config, preset, presets_file, overwrite, chunks, threads, progress, fft_backend : optional
        As for :func:`mann` (``threads``: FFT threads).
    constrain : list, optional
        Condition the field on measurements (Hoffman & Ribak 1991): point series JSON or CSV files, ``turbgen lidar
        --out`` datasets or :func:`turbgen.lidar` reports; each full-rate series' record mean is removed first.
    noise, conditional_mean : optional
        As for :func:`mann`.
    spectrum : str, os.PathLike, Mapping, sequence or callable, optional
        User spectra of u, v, w (``--spectrum``): a CSV file or table (``f_hz``, ``S_u``, ``S_v``, ``S_w``: band-mean
        one-sided PSDs [m^2/s] over the run's lines), or ``S(f_hz) -> (3, n)`` [m^2/s] averaged over each line's band
        (turbgen.theory.user_spectra); the store records the band means.
    coherence : str, os.PathLike, Mapping or callable, optional
        User yz coherence [-] (u, and v, w with ``vw_coherence="exp"``; ``--coherence``): ``coh(f_hz, r_m, U_m_s)``,
        a table ``{"f_hz", "r_m", "coh"}`` or its CSV file (a row per pair) (turbgen.theory.user_coherence); the
        store records the values.

    Returns
    -------
    xarray.Dataset
        u, v, w (t, x, y, z) [m/s] with coordinates and the store's attributes: in memory without ``out``, else the
        written store, opened lazily.

    Raises
    ------
    ParameterError
        For a value outside its range, a field that fits neither memory nor disk, ``noise`` or
        ``conditional_mean`` without ``constrain``, constraint data that do not match the run.
    StoreError
        For an existing ``out`` without ``overwrite``, or an ``out`` that is not a turbgen store with it.

    Warns
    -----
    UserWarning
        When total-wind ``constrain`` data still blow more than 5 deg from the field's x after their mean wind (the
        command's note): the mean of v then enters the field as turbulence.

    Examples
    --------
    >>> import turbgen
    >>> ds = turbgen.kaimal(U=12, nt=128, ny=6, nz=6, planes=[0, 50, 100], seed=2)
    >>> dict(ds.sizes), ds.attrs["model"]
    ({'t': 128, 'x': 3, 'y': 6, 'z': 6}, 'kaimal')
    """
    options = dict(U=U, seed=seed, turb_class=turb_class, hub_height=hub_height, sigma=sigma, lengths=lengths,
                   ayz=ayz, lc=lc, long_model=long_model, ax=ax, bx=bx, long_components=long_components,
                   vw_coherence=vw_coherence, rescale=rescale, planes=planes, gates=gates, nt=nt, dt=dt, ny=ny, nz=nz,
                   dy=dy, dz=dz, spectrum=spectrum)  # fmt: skip
    if not constrain and (noise is not None or conditional_mean):
        raise ParameterError("`noise` and `conditional_mean` need `constrain`")
    run, _ = kaimal_run(options, config, preset, presets_file)
    if coherence is not None:  # as `turbgen kaimal --coherence` (a CSV file), or a callable or table
        run = replace(run, coherence=coherence)
    if constrain:
        from turbgen.runs.constrain import load_constraints
        from turbgen.runs.constrain_kaimal import kaimal_constrained_in_memory

        constraints = load_constraints([constrain] if isinstance(constrain, (str, os.PathLike)) else constrain)
        if out is None:
            return _noted(kaimal_constrained_in_memory(run, constraints, noise_m_s=noise,
                                                       conditional_mean=conditional_mean, threads=threads)[0])
        make = _kaimal_maker(run, overwrite, chunks, threads, progress, constraints, noise, conditional_mean)
    else:
        # straight into the Dataset when the run's arrays with the spectrum in memory and the field fit 80 % of the
        # available memory (the rule by which run_kaimal keeps its spectrum in memory), else through a store
        from turbgen.runs.kaimal import in_memory_bytes, kaimal_in_memory

        available = available_memory_bytes()
        if out is None and (available is None or in_memory_bytes(run) <= 0.8 * available):
            return kaimal_in_memory(run, progress=progress, threads=threads)[0]
        make = _kaimal_maker(run, overwrite, chunks, threads, progress)
    if out is None:  # a field that does not fit: through a temporary store, loaded back
        return _noted(_through_store(make, run.grid, f"kaimal_s{run.seed}.zarr"))
    make(Path(out))
    return _noted(_as_dataset(Path(out)))


def check_kaimal_output(run: KaimalRun, out, chunks, overwrite: bool, threads, constrain=None, noise=None,
                        what: str = "--out") -> tuple[int, list | None]:
    """(peak memory [B], loaded constraints or None) of ``turbgen kaimal`` / ``turbgen.kaimal`` to ``out``, after
    its refusals in run_kaimal's order, before anything is written: an unusable ``out``, a coherence too costly to
    sample, a spectrum that fits neither memory nor disk, ``constrain`` that does not match the run or the memory,
    then the store (existing output, chunks, disk)."""
    from turbgen.runs.kaimal import kaimal_generator, memory_needed, plan_spill

    check_output_path(out, what)
    sampler = kaimal_generator(run, workers=threads).sampler_bytes()
    plan_spill(run.grid, Path(out).absolute(), None, sampler)
    memory, constraints = memory_needed(run.grid, sampler=sampler), None
    if constrain is not None:
        from turbgen.runs.constrain import load_constraints
        from turbgen.runs.constrain_kaimal import constrained_memory_bytes, place_kaimal, require_constrained_memory

        constraints = load_constraints(constrain)
        placed = place_kaimal(run, constraints, noise)
        require_constrained_memory(run, placed, threads)
        memory = constrained_memory_bytes(run, placed, threads)
    check_new_store(out, run.grid, chunk_t=chunks, overwrite=overwrite)
    return memory, constraints


def _kaimal_maker(run: KaimalRun, overwrite, chunks, threads, progress, constraints=None, noise=None,
                  conditional_mean: bool = False):
    """The function writing ``run`` (conditioned on the loaded ``constraints`` if given) to a path as ``turbgen
    kaimal`` does."""
    from turbgen.runs.constrain_kaimal import run_kaimal_constrained
    from turbgen.runs.kaimal import run_kaimal

    def make(path: Path) -> None:
        check_kaimal_output(run, path, chunks, overwrite, threads, constraints, noise, "`out`")
        if constraints is None:
            run_kaimal(run, path, overwrite=overwrite, chunk_t=chunks, progress=progress, threads=threads)
        else:
            run_kaimal_constrained(run, path, constraints, noise_m_s=noise, conditional_mean=conditional_mean,
                                   overwrite=overwrite, chunk_t=chunks, threads=threads)  # fmt: skip

    return make
