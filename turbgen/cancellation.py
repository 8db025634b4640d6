"""Cooperative cancellation of turbgen's writers: the application asks, the writers check before they publish.

An application that stops a run (:mod:`turbgen.interruption`) calls :func:`request_stop`, and every writer calls
:func:`raise_if_stop_requested` just before publishing, so an interruption swallowed on its way up (in a
``__del__``, a weakref callback, a library's ``except``) still publishes nothing."""

from __future__ import annotations

_requests: list[BaseException] = []


def request_stop(exc: BaseException) -> None:
    """Ask every writer of this process to publish nothing and raise (a copy of) ``exc``, e.g. ``SystemExit(143)``."""
    _requests.append(exc)


def stop_requested() -> BaseException | None:
    """The exception of the last stop request, or None."""
    return _requests[-1] if _requests else None


def raise_if_stop_requested() -> None:
    """Raise a fresh copy of the requested exception, if any (writers call it before publishing)."""
    exc = stop_requested()
    if exc is not None:
        raise type(exc)(*exc.args)


def clear_stop_requests() -> None:
    """Forget the stop requests made so far (an application starting its next task in the same process)."""
    _requests.clear()
