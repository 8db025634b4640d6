"""An interrupted sweep silences distributed's shutdown logs for the shutdown only (a library leaves logging as found)
and a close that fails then does not replace the interruption."""

import logging

import pytest

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
