"""finish_before_raising: an interruption of the main thread never leaves the wrapped (zarr) call running."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from turbgen.store.discard import finish_before_raising


def test_an_interrupted_call_runs_to_its_end_before_the_exception_goes_on():
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    done = []

    def slow_write():
        time.sleep(0.5)
        done.append(time.monotonic())

    timer = threading.Timer(0.1, os.kill, (os.getpid(), signal.SIGINT))  # Ctrl-C while the call runs
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        finish_before_raising(slow_write)
    raised = time.monotonic()
    timer.join()
    assert done and done[0] <= raised  # the call had finished when KeyboardInterrupt left


def test_an_interruption_while_the_helper_starts_never_leaves_the_call_running(monkeypatch):
    """A signal landing in Thread.start() (the helper already running): formerly inside ThreadPoolExecutor.submit,
    outside the wait, so a store's zarr.json was written after its temporary directory had been removed. Now the
    call either never runs or ends before the exception goes on."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    real_start, began, done = threading.Thread.start, [], []

    def start(self):
        real_start(self)
        time.sleep(0.05)  # the helper is running the call now
        raise KeyboardInterrupt

    def write():
        began.append(1)
        time.sleep(0.2)
        done.append(1)

    monkeypatch.setattr(threading.Thread, "start", start)
    with pytest.raises(KeyboardInterrupt):
        finish_before_raising(write)
    assert began == done == [1]
    time.sleep(0.3)
    assert began == done == [1]


def test_results_and_errors_of_the_call_pass_through():
    assert finish_before_raising(lambda a, b: a + b, 2, 3) == 5
    with pytest.raises(ValueError, match="bad"):
        finish_before_raising(lambda: (_ for _ in ()).throw(ValueError("bad")))
    out = []
    worker = threading.Thread(target=lambda: out.append(finish_before_raising(threading.current_thread)))
    worker.start()
    worker.join()
    assert out == [worker]  # outside the main thread the call runs in the calling thread itself
