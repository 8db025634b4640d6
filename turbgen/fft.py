"""The FFT seam: every transform turbgen makes goes through the backend this module selects (docs/fft.md).

A backend (:class:`FFTBackend`) gives ``empty(shape, dtype, align)``, aligned buffers (so the plans' rounding
does not depend on where an allocation fell); ``plan(kind, inp, out, axis)``, an unnormalised single-threaded
transform along one axis (FFTW's conventions), one plan set per worker thread, so the field is the same for any
thread count; and ``oneshot``, scipy.fft's functions. Built in: ``pyfftw`` (default) and ``scipy``; others via
:func:`register`. A selection (:func:`use`) holds for the whole process while its call runs (a run's work hops
between threads), so two calls asking for different backends at once are refused."""

from __future__ import annotations

import functools
import os
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, ParamSpec, Protocol, TypeVar

import numpy as np

from turbgen.errors import ParameterError

ENVIRONMENT_VARIABLE = "TURBGEN_FFT_BACKEND"
DEFAULT = "pyfftw"
# the unnormalised transforms a plan makes along its axis
KINDS = ("c2c_forward", "c2c_backward", "r2c", "c2r", "dct1", "dst1")

_P = ParamSpec("_P")
_R = TypeVar("_R")


class _Selection:
    """The backend :func:`use` selected and how many calls hold it (process-wide, behind a lock)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.name: str | None = None
        self.holders = 0


_selected = _Selection()


class Plan(Protocol):
    """A planned transform: ``execute()`` on its arrays, or ``execute(inp, out)`` on others of the same layout."""

    def execute(self, inp: np.ndarray | None = None, out: np.ndarray | None = None) -> None: ...


class FFTBackend(Protocol):
    """What turbgen asks of an FFT backend (see the module's docstring)."""

    name: str
    oneshot: Any

    def empty(self, shape: tuple[int, ...], dtype, align: int = 64) -> np.ndarray: ...

    def plan(self, kind: str, inp: np.ndarray, out: np.ndarray, axis: int) -> Plan: ...


def aligned_empty(shape, dtype, align: int = 64) -> np.ndarray:
    """An uninitialised C-ordered host array whose first element is ``align``-byte aligned."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    raw = np.empty(nbytes + align, np.uint8)
    start = -raw.ctypes.data % align
    return raw[start : start + nbytes].view(dtype).reshape(shape)


class _ScipyPlan:
    """A 'plan' of scipy.fft: the call made at each execution (pocketfft caches its own twiddle factors)."""

    def __init__(self, kind: str, inp: np.ndarray, out: np.ndarray, axis: int):
        import scipy.fft

        n = out.shape[axis]
        calls = {
            "c2c_forward": lambda x: scipy.fft.fft(x, axis=axis, workers=1),
            "c2c_backward": lambda x: scipy.fft.ifft(x, axis=axis, norm="forward", workers=1),
            "r2c": lambda x: scipy.fft.rfft(x, axis=axis, workers=1),
            "c2r": lambda x: scipy.fft.irfft(x, n=n, axis=axis, norm="forward", workers=1),
            "dct1": lambda x: scipy.fft.dct(x, type=1, axis=axis, workers=1),
            "dst1": lambda x: scipy.fft.dst(x, type=1, axis=axis, workers=1),
        }
        self._call, self._inp, self._out = calls[kind], inp, out

    def execute(self, inp: np.ndarray | None = None, out: np.ndarray | None = None) -> None:
        inp = self._inp if inp is None else inp
        out = self._out if out is None else out
        out[...] = self._call(inp)


class ScipyBackend:
    """scipy.fft (pocketfft) for every transform: no pyfftw needed."""

    name = "scipy"
    empty = staticmethod(aligned_empty)

    def __init__(self):
        import scipy.fft

        self.oneshot = scipy.fft

    def plan(self, kind: str, inp: np.ndarray, out: np.ndarray, axis: int) -> Plan:
        return _ScipyPlan(kind, inp, out, axis)


class _FFTWPlan:
    """A pyfftw.FFTW plan; ``execute(inp, out)`` swaps its arrays first (pyfftw's update_arrays)."""

    def __init__(self, plan):
        self._plan = plan

    def execute(self, inp: np.ndarray | None = None, out: np.ndarray | None = None) -> None:
        if inp is not None:
            self._plan.update_arrays(inp, out)
        self._plan.execute()


class PyfftwBackend:
    """pyfftw for planned transforms (FFTW_ESTIMATE: the same plan in every process); scipy.fft for the others."""

    name = "pyfftw"
    empty = staticmethod(aligned_empty)
    _DIRECTIONS = {"c2c_forward": "FFTW_FORWARD", "c2c_backward": "FFTW_BACKWARD", "r2c": "FFTW_FORWARD",
                   "c2r": "FFTW_BACKWARD", "dct1": ["FFTW_REDFT00"], "dst1": ["FFTW_RODFT00"]}  # fmt: skip

    def __init__(self):
        import pyfftw
        import scipy.fft

        self._pyfftw, self.oneshot = pyfftw, scipy.fft

    def plan(self, kind: str, inp: np.ndarray, out: np.ndarray, axis: int) -> Plan:
        flags = ("FFTW_ESTIMATE", "FFTW_DESTROY_INPUT") if kind == "c2r" else ("FFTW_ESTIMATE",)
        return _FFTWPlan(self._pyfftw.FFTW(inp, out, axes=(axis,), direction=self._DIRECTIONS[kind], flags=flags,
                                           threads=1))  # fmt: skip


_REGISTRY: dict[str, Callable[[], FFTBackend]] = {"pyfftw": PyfftwBackend, "scipy": ScipyBackend}
_MADE: dict[str, FFTBackend] = {}


def register(name: str, factory: Callable[[], FFTBackend]) -> None:
    """Make ``factory()`` the backend called ``name`` (``--fft-backend name``, ``fft_backend=name``, the variable);
    it runs on first use, so a backend's library is imported only by the runs using it."""
    _REGISTRY[name] = factory
    _MADE.pop(name, None)


def names() -> tuple[str, ...]:
    """The registered backends' names."""
    return tuple(_REGISTRY)


def check_name(name: str, what: str = "FFT backend") -> str:
    """``name`` if it is a registered backend, else a ParameterError naming it and the allowed ones."""
    if name not in _REGISTRY:
        raise ParameterError(f"unknown {what} {name!r} (allowed: {', '.join(_REGISTRY)})")
    return name


def current() -> str:
    """The name of the backend that runs now: :func:`use`'s, else ``TURBGEN_FFT_BACKEND``'s, else ``pyfftw``."""
    name = _selected.name
    if name is not None:
        return name
    return check_name(os.environ.get(ENVIRONMENT_VARIABLE) or DEFAULT, f"FFT backend in {ENVIRONMENT_VARIABLE}:")


def backend(name: str | None = None) -> FFTBackend:
    """The backend called ``name`` (None: :func:`current`), made once per process."""
    name = check_name(name) if name is not None else current()
    if name not in _MADE:
        try:
            _MADE[name] = _REGISTRY[name]()
        except ImportError as exc:
            others = ", ".join(n for n in _REGISTRY if n != name)
            raise ParameterError(f"FFT backend {name!r} is not available ({exc}); choose another: {others}") from None
    return _MADE[name]


def oneshot(name: str | None = None):
    """The one-shot transforms (scipy.fft's functions and signatures) of backend ``name`` (None: the current one)."""
    return backend(name).oneshot


@contextmanager
def use(name: str | None) -> Iterator[str]:
    """Run the block with backend ``name`` (None: leave the selection as it is) in every thread of the process;
    yields the backend's name. ParameterError for an unknown name, or while another call holds a different one."""
    if name is None:
        yield current()
        return
    check_name(name)
    with _selected.lock:
        if _selected.holders and _selected.name != name:
            raise ParameterError(f"FFT backend {name!r} asked for while another call of this process runs with "
                                 f"{_selected.name!r}: one backend at a time")  # fmt: skip
        _selected.name, _selected.holders = name, _selected.holders + 1
    try:
        yield name
    finally:
        with _selected.lock:
            _selected.holders -= 1
            if not _selected.holders:
                _selected.name = None


def selected_by_keyword(function: Callable[_P, _R]) -> Callable[_P, _R]:
    """Decorator: the function's ``fft_backend`` keyword (declared in its signature, default None) selects the backend
    for the whole call (:func:`use`), so every transform made under it, however deep, uses that backend."""

    @functools.wraps(function)
    def selected(*args, **kwargs):
        with use(kwargs.get("fft_backend")):
            return function(*args, **kwargs)

    return selected


def fftfreq(n: int, d: float = 1.0) -> np.ndarray:
    """The sample frequencies of an n-point DFT with spacing ``d`` (numpy.fft.fftfreq: no transform, any backend)."""
    return np.fft.fftfreq(n, d)


def rfftfreq(n: int, d: float = 1.0) -> np.ndarray:
    """The sample frequencies of an n-point real DFT (numpy.fft.rfftfreq: no transform, any backend)."""
    return np.fft.rfftfreq(n, d)


def fftshift(x: np.ndarray, axes=None) -> np.ndarray:
    """Zero lag in the middle (numpy.fft.fftshift: an index shift, any backend)."""
    return np.fft.fftshift(x, axes=axes)


def next_fast_len(n: int) -> int:
    """The smallest 11-smooth length >= n (scipy.fft.next_fast_len): fast for every built-in backend."""
    import scipy.fft

    return int(scipy.fft.next_fast_len(n))
