"""`turbgen serve` on a full disk (issue 37 §2): a run that meets ENOSPC is marked failed with its one line, and a
run whose server died while running it (the SIGBUS crash loop) is failed after MAX_STARTS starts, not re-queued
forever."""

from __future__ import annotations

import pytest

from service_server import TINY_GRID
from turbgen.service.catalog import FAILURE_ROOM, Catalog
from turbgen.service.jobs import MAX_STARTS, Jobs
from turbgen.service.run_ids import build_run, canonical_mapping, run_id


def _recorded(catalog: Catalog, seed: int = 1) -> str:
    model, run, constraints = build_run({"model": "mann", "seed": seed, "U_m_s": 10.0, "grid": dict(TINY_GRID)})
    mapping = canonical_mapping(run, constraints)
    rid = run_id(model, mapping)
    catalog.record(rid, model, mapping)
    return rid


class _NoClient:
    """A dask client that must not be asked to compute anything."""

    def submit(self, *args, **kwargs):
        raise AssertionError("a run that already took its server down MAX_STARTS times was started again")


def test_a_run_started_max_starts_times_is_failed_not_requeued(tmp_path):
    catalog = Catalog(tmp_path / "root")
    rid = _recorded(catalog)
    for _ in range(MAX_STARTS):  # each start, then the server died (nothing marked it complete or failed)
        catalog.count_start(rid)
    assert catalog.starts(rid) == MAX_STARTS
    assert Jobs(catalog, _NoClient(), max_queue=4).resume() == []
    reason = catalog.failure(rid)
    assert reason is not None and f"{MAX_STARTS} times" in reason and "\n" not in reason


def test_a_run_started_fewer_times_is_requeued(tmp_path):
    catalog = Catalog(tmp_path / "root")
    rid = _recorded(catalog)
    catalog.count_start(rid)
    started = []

    class Client:
        def submit(self, *args, **kwargs):
            started.append(kwargs["key"])
            return _Done()

    assert Jobs(catalog, Client(), max_queue=4).resume() == [rid]
    assert len(started) == 1 and catalog.starts(rid) == 2 and catalog.failure(rid) is None


class _Done:
    def add_done_callback(self, fn):
        pass


def test_a_full_disk_still_records_the_failure(tmp_path, small_disk):
    disk = small_disk("1M")
    catalog = Catalog(disk / "root")
    rid = _recorded(catalog)
    assert (catalog.run_dir(rid) / FAILURE_ROOM).is_file()
    _fill(disk / "filler")
    with pytest.raises(OSError):
        (disk / "probe").write_bytes(b"x")  # the disk is full indeed
    catalog.mark_failed(rid, "ParameterError: the disk is full")
    assert catalog.failure(rid) == "ParameterError: the disk is full"
    assert not (catalog.run_dir(rid) / FAILURE_ROOM).exists()


def _fill(path) -> None:
    """Write zeros to ``path`` until the file system refuses one more byte."""
    import errno
    import os

    fd = os.open(path, os.O_WRONLY | os.O_CREAT)
    try:
        for size in (2**16, 4096, 1):
            try:
                while True:
                    os.write(fd, bytes(size))
            except OSError as exc:
                assert exc.errno == errno.ENOSPC
    finally:
        os.close(fd)


def test_a_run_on_a_full_disk_is_marked_failed_in_one_line(tmp_path, small_disk):
    from inprocess_server import InProcessServer

    disk = small_disk("4M")
    srv = InProcessServer(disk / "root")
    try:
        with open(disk / "filler", "wb") as f:  # leave ~100 KiB: the request fits, the store does not
            f.write(bytes(4 * 2**20 - 100 * 2**10 - sum(p.stat().st_size for p in disk.rglob("*") if p.is_file())))
        status, _, body = srv.call("POST", "/runs", {"model": "mann", "seed": 3, "U_m_s": 10.0,
                                                     "grid": dict(TINY_GRID)})  # fmt: skip
        assert status in (200, 201, 202), body
        state = _wait_failed(srv, body["id"])
        assert "disk" in state["error"] and "\n" not in state["error"], state
        assert not [p for p in (disk / "root" / "runs" / body["id"]).iterdir() if p.name.startswith(".")]
    finally:
        srv.stop()


def _wait_failed(srv, rid: str, timeout_s: float = 300.0) -> dict:
    import time

    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        s = srv.call("GET", f"/runs/{rid}")[2]
        if s["status"] in ("failed", "complete"):
            assert s["status"] == "failed", s
            return s
        time.sleep(0.2)
    raise AssertionError(f"run {rid} neither failed nor completed within {timeout_s} s")


def test_a_run_that_cannot_be_recorded_is_refused_with_507(tmp_path, small_disk):
    from turbgen.service.limits import LimitError

    disk = small_disk("1M")
    catalog = Catalog(disk / "root")
    _fill(disk / "filler")
    model, run, constraints = build_run({"model": "mann", "seed": 9, "U_m_s": 10.0, "grid": dict(TINY_GRID)})
    rid = run_id(model, canonical_mapping(run, constraints))
    with pytest.raises(LimitError) as err:
        Jobs(catalog, _NoClient(), max_queue=4).submit(rid, model, run, None, constraints)
    assert err.value.status == 507 and "cannot record the run" in str(err.value)
    assert catalog.ids() == []
