"""Interruption handling of the applications (command line, sweep): signals become exceptions, writers are told.

Application layer: the library (theory ... lidar) installs no signal handler and no ``sys.unraisablehook``; its
writers stay safe anyway (temporary names, atomic publish, :mod:`turbgen.cancellation`). Within
:func:`exit_on_signals`, SIGTERM and SIGHUP raise ``SystemExit(128 + signum)`` in the main thread so that
``with``-block clean-up runs as it does for Ctrl-C (``KeyboardInterrupt``), and each signal is recorded
(:func:`received_signal`) and passed to the writers as a stop request.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading

from turbgen.cancellation import clear_stop_requests, request_stop, stop_requested

_received: list[int] = []


def received_signal() -> int | None:
    """The signal number that :func:`exit_on_signals` turned into an exception, if one arrived.

    Library code running when the signal lands may replace the ``SystemExit`` (``KeyboardInterrupt`` for
    SIGINT) with an exception of its own (h5py turns an exception raised inside an attribute write into
    ``TypeError``); the CLI asks this to report the interruption, not the replacement.

    Returns
    -------
    int or None
        The last signal number received, or None.
    """
    return _received[-1] if _received else None


def forget_signals() -> None:
    """Forget the signals recorded so far and their stop requests (the CLI calls it when a command starts).

    Returns
    -------
    None
    """
    _received.clear()
    clear_stop_requests()


def _record(signum: int) -> BaseException:
    exc = KeyboardInterrupt() if signum == signal.SIGINT else SystemExit(128 + signum)
    _received.append(signum)
    request_stop(exc)
    return exc


def _exit_on_signal(signum, frame):
    raise _record(signum)


def _quiet_about_signals(unraisable) -> None:
    """sys.unraisablehook: say nothing about our signal's exception where Python could not raise it (a
    weakref callback, a ``__del__``: "Exception ignored in ..." and a traceback); the writers' publish check
    (:func:`turbgen.cancellation.raise_if_stop_requested`) acts on it instead. Anything else goes to the
    default hook."""
    if stop_requested() is not None and issubclass(unraisable.exc_type, (SystemExit, KeyboardInterrupt)):
        return
    sys.__unraisablehook__(unraisable)


@contextlib.contextmanager
def exit_on_signals():
    """Within the block, SIGTERM and SIGHUP raise SystemExit(128 + signum) in the main thread, and SIGINT raises
    KeyboardInterrupt as usual; each is recorded for :func:`received_signal` and requested as a stop of the writers.

    Only default handlers are replaced (a caller's own handler, or an ignored signal as under ``nohup``, is kept);
    outside the main thread this does nothing (Python delivers signals to the main thread only). The previous
    handlers and ``sys.unraisablehook`` are restored, and the stop requests cleared, on leaving the block (the
    writers within it have acted on them; :func:`received_signal` still tells what arrived).

    Yields
    ------
    None

    Raises
    ------
    SystemExit
        Code 128 + signum, when SIGTERM or SIGHUP arrives within the block.
    KeyboardInterrupt
        When SIGINT arrives within the block.
    """
    old = {}
    hook = sys.unraisablehook
    main = threading.current_thread() is threading.main_thread()
    if main:
        sys.unraisablehook = _quiet_about_signals
        for sig in (signal.SIGTERM, signal.SIGHUP):
            if signal.getsignal(sig) == signal.SIG_DFL:
                old[sig] = signal.signal(sig, _exit_on_signal)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # Ctrl-C: recorded as well
            old[signal.SIGINT] = signal.signal(signal.SIGINT, _exit_on_signal)
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        if main:
            sys.unraisablehook = hook
        clear_stop_requests()
