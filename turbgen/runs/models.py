"""The model registry: model name -> run class, run function, memory estimates (for the sweep and the service);
``MODELS`` resolves each turbgen.spec.models declaration's ``runner`` (a model's ``turbgen.runs.<name>:MODEL``) on
first use."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass

from turbgen.spec.models import declaration, model_names, resolve


@dataclass(frozen=True)
class Model:
    """One model of the registry. ``shared_part(run, threads, memory_bytes)``: ``build(run)`` of the part runs with
    equal ``shared_key(run)`` share (the ae-free Mann stencil), or None."""

    name: str  # the store's ``model`` attribute
    spec: type  # the run class
    run: Callable[..., dict]  # ``run(run, out, *, overwrite, chunk_t, threads, memory_bytes, shared)`` -> summary
    memory_bytes: Callable[[object, int], int]  # ``memory_bytes(run, threads)`` -> peak bytes [B] of a run in memory
    least_memory_bytes: Callable[[object], int]  # -> the smallest footprint [B] a run can be made with
    memory_fields: str  # the run fields that lower the memory (for messages)
    shared_part: Callable[[object, int | None, int | None], Callable | None]
    shared_key: Callable[[object], object] = lambda run: None
    shared_bytes: Callable[[object], int] = lambda run: 0  # the shared part's bytes [B]
    out_of_core: bool = False  # a memory budget bounds the run (over it, made out of core)


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
