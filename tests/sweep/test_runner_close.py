"""An interrupted sweep silences distributed's shutdown logs for the shutdown only (a library leaves logging as found)
and a close that fails then does not replace the interruption; a signal during the cluster's start-up is raised after
it."""

import logging
import signal
import threading
import time
from types import SimpleNamespace

import distributed
import pytest

from turbgen.sweep import runner
from turbgen.sweep.runner import close_quietly


class _Closable:
    def __init__(self, fail=False):
        self.levels, self.fail = [], fail

    def close(self):
        self.levels.append(logging.getLogger("distributed").level)
        if self.fail:
            raise RuntimeError("close failed")


@pytest.mark.parametrize("quiet", [True, False])
def test_the_logger_level_is_restored_after_closing(quiet):
    log = logging.getLogger("distributed")
    before = log.level
    log.setLevel(logging.WARNING)
    try:
        client, cluster = _Closable(), _Closable()
        close_quietly(client, None, cluster, quiet=quiet)
        during = logging.CRITICAL + 1 if quiet else logging.WARNING
        assert client.levels == cluster.levels == [during]
        assert log.level == logging.WARNING
        second = _Closable()
        if quiet:  # shutting down after an interruption: a failing close does not replace it, the rest still close
            close_quietly(_Closable(fail=True), second, quiet=True)
            assert second.levels == [logging.CRITICAL + 1]
        else:
            with pytest.raises(RuntimeError):
                close_quietly(_Closable(fail=True), second, quiet=False)
        assert log.level == logging.WARNING  # restored when closing fails too
    finally:
        log.setLevel(before)


def test_a_signal_taken_by_another_thread_during_the_start_up_is_raised_after_it(monkeypatch):
    """The start-up blocks the signals in the main thread only: a thread made before it (BLAS's, a pool's) takes a
    process-directed Ctrl-C, and Python runs the handler in the main thread at once, inside distributed's start-up
    (which may swallow it: a CI run saw a sweep interrupted 5 s into its start-up run to its end with exit 0). The
    start-up must finish and the interruption come after it, with the cluster closed quietly."""
    events, stop = [], threading.Event()

    def start(n, threads, processes):
        signal.pthread_kill(helper.ident, signal.SIGINT)  # the kernel's choice of thread for killpg's signal
        t0 = time.monotonic()
        while time.monotonic() - t0 < 0.3:  # bytecode runs here: a handler would run within it
            pass
        events.append("started")
        return SimpleNamespace()

    monkeypatch.setattr("turbgen.runs.local_cluster.loopback_cluster", start)
    monkeypatch.setattr(distributed, "Client", lambda cluster: SimpleNamespace(run=lambda fn: {}))
    monkeypatch.setattr(runner, "close_quietly", lambda *closables, quiet: events.append(("closed", quiet)))
    helper = threading.Thread(target=stop.wait)  # does not block SIGINT: made before the start-up's mask
    helper.start()
    try:
        with pytest.raises(KeyboardInterrupt), runner._own_client(SimpleNamespace(scheduler=None), 2, True):
            events.append("body")
    finally:
        stop.set()
        helper.join()
    assert events == ["started", ("closed", True)]
