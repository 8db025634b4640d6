"""The model registry: model name -> run class, run function, memory estimates (for the sweep and the service);
``MODELS`` resolves each turbgen.spec.models declaration's ``runner`` (:data:`MANN`, :data:`KAIMAL`) on first use."""

from __future__ import annotations

import functools
import importlib
import os
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass

from turbgen.resources import available_memory_bytes
from turbgen.spec.kaimal import KaimalRun
from turbgen.spec.mann import MannRun
from turbgen.spec.models import declaration, model_names, resolve


@dataclass(frozen=True)
class Model:
    """One model of the registry.

    name : the store's ``model`` attribute. spec : the run class.
    run : ``run(run, out, *, overwrite, chunk_t, threads, memory_bytes, shared)`` -> summary dict.
    memory_bytes : ``memory_bytes(run, threads)`` -> peak bytes [B] of a run in memory.
    least_memory_bytes : ``least_memory_bytes(run)`` -> the smallest footprint [B] a run can be made with.
    memory_fields : the run fields that lower the memory (for messages).
    shared_part : ``shared_part(run, threads, memory_bytes)`` -> ``build(run)`` of the part runs with equal
        ``shared_key(run)`` share (the ae-free Mann stencil), or None. shared_bytes : its bytes [B].
    out_of_core : a memory budget bounds the run (over it, made out of core).
    """

    name: str
    spec: type
    run: Callable[..., dict]
    memory_bytes: Callable[[object, int], int]
    least_memory_bytes: Callable[[object], int]
    memory_fields: str
    shared_part: Callable[[object, int | None, int | None], Callable | None]
    shared_key: Callable[[object], object] = lambda run: None
    shared_bytes: Callable[[object], int] = lambda run: 0
    out_of_core: bool = False


def _mann(name: str, *bound) -> Callable:
    """turbgen.runs.mann's function ``name`` (imported when called) with ``bound`` arguments appended."""
    return lambda *args: getattr(importlib.import_module("turbgen.runs.mann"), name)(*args, *bound)


def _mann_out_of_core(run: MannRun, threads: int | None, memory_bytes: int | None) -> bool:
    """Whether a Mann run exceeds its memory budget (then mann_outofcore makes it)."""
    if memory_bytes is None:
        return False
    from turbgen.runs.mann_outofcore import fits_in_memory

    return not fits_in_memory(run, memory_bytes, threads or os.cpu_count() or 1)


def _run_mann(run: MannRun, out, *, overwrite=False, chunk_t=None, threads=None, memory_bytes=None, shared=None):
    if _mann_out_of_core(run, threads, memory_bytes):
        from turbgen.runs.mann_outofcore import run_mann_outofcore

        return run_mann_outofcore(run, out, memory_bytes=memory_bytes, overwrite=overwrite, chunk_t=chunk_t,
                                  threads=threads)
    from turbgen.runs.mann import run_mann

    return run_mann(run, out, overwrite=overwrite, chunk_t=chunk_t, stencil=shared, threads=threads)


def _mann_shared(run: MannRun, threads: int | None, memory_bytes: int | None):
    if _mann_out_of_core(run, threads, memory_bytes):
        return None
    from turbgen.runs.mann import build_mann_stencil

    return functools.partial(build_mann_stencil, energy="unit")  # picklable: a sweep's workers build it


def _run_kaimal(run: KaimalRun, out, *, overwrite=False, chunk_t=None, threads=None, memory_bytes=None, shared=None):
    from turbgen.runs.kaimal import run_kaimal

    return run_kaimal(run, out, overwrite=overwrite, chunk_t=chunk_t, threads=threads)


def _kaimal_memory(run: KaimalRun, threads: int) -> int:
    from turbgen.runs.kaimal import kaimal_generator, memory_needed

    return memory_needed(run.grid, sampler=kaimal_generator(run, workers=threads).sampler_bytes())


def _kaimal_least_memory(run: KaimalRun) -> int:
    from turbgen.runs.kaimal import kaimal_generator, memory_needed

    floor = min(memory_needed(run.grid), memory_needed(run.grid, True))  # memory or disk, samplers not counted
    available = available_memory_bytes()
    if available is not None and floor > available:
        # the samplers only add: refused without planning a torus per frequency (minutes for 8 M bins)
        return floor
    sampler = kaimal_generator(run, workers=1).sampler_bytes()
    return min(memory_needed(run.grid, sampler=sampler), memory_needed(run.grid, True, sampler))


MANN = Model("mann", MannRun, _run_mann, _mann("memory_estimate_bytes"), _mann("memory_estimate_bytes", 1),
             "`nt`, `ny`/`nz` or `pad_yz`", _mann_shared, _mann("shared_stencil_key"), _mann("shared_stencil_nbytes"),
             out_of_core=True)
KAIMAL = Model("kaimal", KaimalRun, _run_kaimal, _kaimal_memory, _kaimal_least_memory,
               "`nt`, `ny`/`nz` or the number of planes", lambda run, threads, memory_bytes: None)


class _Runners(Mapping):
    """Model name -> :class:`Model`, each resolved when asked for."""

    def __getitem__(self, name: str) -> Model:
        if name not in model_names():
            raise KeyError(name)
        return resolve(declaration(name).runner, "runs")

    def __iter__(self) -> Iterator[str]:
        return iter(model_names())

    def __len__(self) -> int:
        return len(model_names())


MODELS: Mapping[str, Model] = _Runners()


def get_model(name: str) -> Model:
    """The registry entry of ``name``; ParameterError listing the models otherwise."""
    return MODELS[declaration(name).name]
