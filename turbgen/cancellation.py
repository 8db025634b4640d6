"""Cooperative cancellation of turbgen's writers: the application asks, the writers check before they publish.

turbgen's writers (field stores, exports) work under temporary names and publish atomically, so an exception that
leaves their ``with`` block publishes nothing. An application that stops a run (the command line on a signal, see
:mod:`turbgen.interruption`) also calls :func:`request_stop`, and every writer calls :func:`raise_if_stop_requested`
just before publishing: an interruption whose exception was swallowed on its way up (in a ``__del__``, a weakref
callback or a library's own ``except``) still publishes nothing. The library installs no handler of any kind.
"""

from __future__ import annotations

_requests: list[BaseException] = []


def request_stop(exc: BaseException) -> None:
    """Ask every writer of this process to publish nothing and raise (a copy of) ``exc`` instead.

    Parameters
    ----------
    exc : BaseException
        The exception the writers raise, e.g. ``KeyboardInterrupt()`` or ``SystemExit(143)``.

    Returns
    -------
    None
    """
    _requests.append(exc)


def stop_requested() -> BaseException | None:
    """The exception of the last stop request, or None when none was made (or all were cleared).

    Returns
    -------
    BaseException or None
        The requested exception.
    """
    return _requests[-1] if _requests else None


def raise_if_stop_requested() -> None:
    """Raise a fresh copy of the requested exception when a stop was requested; the writers call it before publishing.

    Returns
    -------
    None

    Raises
    ------
    BaseException
        A new instance of the requested exception's class with its arguments.
    """
    exc = stop_requested()
    if exc is not None:
        raise type(exc)(*exc.args)


def clear_stop_requests() -> None:
    """Forget the stop requests made so far (an application starting its next task in the same process).

    Returns
    -------
    None
    """
    _requests.clear()
