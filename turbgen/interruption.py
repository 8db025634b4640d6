"""Interruption handling of the applications (command line, sweep): signals become exceptions, writers are told.

Application layer only: the library installs no signal handler and no ``sys.unraisablehook``; its writers
are safe anyway (temporary names, atomic publish, :mod:`turbgen.cancellation`)."""

from __future__ import annotations

import contextlib
import signal
import sys
import threading

from turbgen.cancellation import clear_stop_requests, request_stop, stop_requested

_received: list[int] = []


def received_signal() -> int | None:
    """The last signal number :func:`exit_on_signals` turned into an exception, or None: the CLI reports the
    interruption, not what library code replaced the exception with (h5py: ``TypeError``)."""
    return _received[-1] if _received else None


def forget_signals() -> None:
    """Forget the signals recorded so far and their stop requests (the CLI calls it when a command starts)."""
    _received.clear()
    clear_stop_requests()


def _exit_on_signal(signum, frame):
    exc = KeyboardInterrupt() if signum == signal.SIGINT else SystemExit(128 + signum)
    _received.append(signum)
    request_stop(exc)
    raise exc


def _quiet_about_signals(unraisable) -> None:
    """sys.unraisablehook: silent about our signal's exception where Python could not raise it (a weakref
    callback, a ``__del__``; the writers' publish check acts on it); anything else goes to the default hook."""
    if stop_requested() is not None and issubclass(unraisable.exc_type, (SystemExit, KeyboardInterrupt)):
        return
    sys.__unraisablehook__(unraisable)


@contextlib.contextmanager
def exit_on_signals():
    """Within the block SIGTERM and SIGHUP raise SystemExit(128 + signum) in the main thread, SIGINT KeyboardInterrupt.

    So ``with``-block clean-up runs as for Ctrl-C; each signal is recorded for :func:`received_signal` and
    requested as a stop of the writers. Only default handlers are replaced (a caller's own, or an ignored
    signal under ``nohup``, is kept); outside the main thread nothing is done. The handlers and
    ``sys.unraisablehook`` are restored and the stop requests cleared on leaving the block."""
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
