"""`turbgen serve` security and limits: token, body size, memory budget, queue length, bad requests,
restart after kill -9. Real server processes on loopback ports."""

from __future__ import annotations

import json
import os
from pathlib import Path
import subprocess
import sys
import time

import pytest

import turbgen

from service_server import TINY_GRID, Server

TOKEN = "s3cret-token-for-tests-0123456789"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
# a run taking a few seconds: long enough to be caught mid-way by kill -9 or to fill a queue of one
SLOW_GRID = {"nt": 2048, "ny": 16, "nz": 16, "x_m": [0.0, 20.0, 40.0, 60.0]}


@pytest.fixture(scope="module")
def guarded(tmp_path_factory):
    root = tmp_path_factory.mktemp("guarded") / "root"
    token_file = root.parent / "token"
    token_file.write_text(TOKEN + "\n")
    srv = Server(root, "--token-file", str(token_file), "--max-queue", "1", "--memory-budget", "0.5")
    yield srv
    srv.kill()


def _run(seed, grid=TINY_GRID):
    return {"model": "mann", "seed": seed, "U_m_s": 10.0, "grid": dict(grid)}


def test_non_loopback_host_needs_a_token_file(tmp_path):
    cmd = [sys.executable, "-c", "from turbgen.cli import main; main()", "serve", "--host", "0.0.0.0",
           "--root", str(tmp_path / "root")]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "--token-file" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "root").exists()


def test_scheduler_that_does_not_answer_is_refused_in_one_line(tmp_path):
    # found with `turbgen serve --scheduler tcp://127.0.0.1:1`: dask's Client retried for 30 s, then
    # "Error: OSError (errno None)"; now the sweep's check of the address, within its 3 s probe
    cmd = [sys.executable, "-c", "from turbgen.cli import main; main()", "serve", "--scheduler", "tcp://127.0.0.1:1",
           "--root", str(tmp_path / "root"), "--port", "0"]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=25)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines() == [done.stderr.strip()] and "tcp://127.0.0.1:1" in done.stderr
    assert "cannot connect" in done.stderr and not (tmp_path / "root").exists()


def test_mutating_requests_need_the_token(guarded):
    assert guarded.call("POST", "/runs", _run(1))[0] == 401
    status, hdrs, _ = guarded.call("POST", "/runs", _run(1), headers={"Authorization": "Bearer wrong"})
    assert status == 401 and hdrs["www-authenticate"] == "Bearer"
    assert guarded.call("POST", "/sweeps", {"models": ["mann"]})[0] == 401
    assert guarded.call("DELETE", "/runs/" + "0" * 24)[0] == 401
    status, _, out = guarded.call("POST", "/runs", _run(1), headers=AUTH)
    assert status == 202
    guarded.wait(out["id"])
    assert guarded.call("GET", f"/runs/{out['id']}")[0] == 200  # reading needs no token


def test_computing_a_derived_product_needs_the_token(guarded):
    """Found by the service probe: on a server with a token, GET export / validation / lidar / plots started
    computations (and wrote cached files) for anyone. Now only a request with the token starts them; what is
    cached stays readable without it."""
    status, _, out = guarded.call("POST", "/runs", _run(11), headers=AUTH)
    assert status in (200, 202)
    rid = out["id"]
    guarded.wait(rid)
    for path in (f"/runs/{rid}/export?format=bts", f"/runs/{rid}/validation", f"/runs/{rid}/lidar",
                 f"/runs/{rid}/plots/spectrum_u.png"):  # fmt: skip
        assert guarded.call("GET", path)[0] == 401, path
    assert not (guarded.root / "runs" / rid / "validation").exists()
    assert not (guarded.root / "runs" / rid / "exports").exists()
    assert guarded.call("GET", f"/runs/{rid}/validation", headers=AUTH)[0] == 200
    assert guarded.call("GET", f"/runs/{rid}/validation")[0] == 200  # cached: reading needs no token


def test_limits_413_and_429(guarded):
    status, _, out = guarded.call("POST", "/runs", raw=b"{" + b" " * 70000 + b"}", headers=AUTH)
    assert status == 413 and "body" in out["detail"]
    big = _run(2, {"nt": 65536, "ny": 64, "nz": 64, "x_m": [0.0, 50.0]})
    status, _, out = guarded.call("POST", "/runs", big, headers=AUTH)
    assert status == 413 and "grid" in out["detail"] and "--memory-budget" in out["detail"] and "GiB" in out["detail"]
    status, _, slow = guarded.call("POST", "/runs", _run(3, SLOW_GRID), headers=AUTH)
    assert status == 202
    status, hdrs, out = guarded.call("POST", "/runs", _run(4), headers=AUTH)
    assert status == 429 and int(hdrs["retry-after"]) > 0
    assert guarded.call("POST", "/runs", _run(3, SLOW_GRID), headers=AUTH)[2]["submitted"] in ("joined", "complete")
    guarded.wait(slow["id"], timeout_s=120)
    assert guarded.call("POST", "/runs", _run(4), headers=AUTH)[0] == 202


def test_a_run_whose_store_is_published_holds_no_queue_place(tmp_path):
    """Found by CI (test_limits_413_and_429): a client saw its run complete and submitted the next one, which got
    429, as the run left the queue only when its worker's result came back, a moment after the store's publication."""
    from turbgen.service.catalog import Catalog
    from turbgen.service.jobs import Jobs
    from turbgen.service.limits import LimitError
    from turbgen.service.run_ids import build_run, canonical_mapping, run_id

    class Pending:  # a worker that has not answered yet
        def add_done_callback(self, fn):
            pass

    class Client:
        def submit(self, *args, **kwargs):
            return Pending()

    catalog = Catalog(tmp_path / "root")
    jobs = Jobs(catalog, Client(), max_queue=1)
    runs = [build_run({"model": "mann", "seed": s, "U_m_s": 10.0, "grid": dict(TINY_GRID)}) for s in (1, 2)]
    rids = [run_id(model, canonical_mapping(run, c)) for model, run, c in runs]
    assert jobs.submit(rids[0], *runs[0][:2]) == "queued"
    with pytest.raises(LimitError) as err:
        jobs.submit(rids[1], *runs[1][:2])
    assert err.value.status == 429 and "1 runs are queued or running" in str(err.value)
    turbgen.mann(nt=16, ny=4, nz=4, planes=[0], pad_yz=1, out=catalog.store_path(rids[0]))  # the worker published
    assert jobs.submit(rids[1], *runs[1][:2]) == "queued" and set(jobs.active) == set(rids)


_SERVER_FILE = Path(turbgen.__file__).parent / "schemas" / "lidar.schema.json"  # exists on the server


def _SWEEP_WITH(key, value):
    doc = {"models": ["mann"], "presets": ["neutral"], "speeds": [10], "seeds": [1], key: value}
    return json.dumps(doc).encode()


BAD = [
    ("POST", "/runs", b"not json", 422, None),
    ("POST", "/runs", b"[1, 2]", 422, "JSON object"),
    ("POST", "/runs", b'"text"', 422, "JSON object"),
    ("POST", "/runs", b"", 422, None),
    ("POST", "/runs", b'{"model": "lattice"}', 422, "model"),
    ("POST", "/runs", b'{"U_m_s": -3}', 422, "U_m_s"),
    ("POST", "/runs", b'{"U_m_s": "fast"}', 422, "U_m_s"),
    ("POST", "/runs", b'{"seed": -1}', 422, "seed"),
    ("POST", "/runs", b'{"seed": 1.5}', 422, "seed"),
    ("POST", "/runs", b'{"gamma": 1e9}', 422, "gamma"),
    ("POST", "/runs", b'{"unknown_key": 1}', 422, "unknown_key"),
    ("POST", "/runs", b'{"grid": {"nt": 1}}', 422, "nt"),
    ("POST", "/runs", b'{"grid": {"ny": 0}}', 422, "ny"),
    ("POST", "/runs", b'{"grid": {"x_m": []}}', 422, "x_m"),
    ("POST", "/runs", b'{"grid": "big"}', 422, "grid"),
    ("POST", "/runs", b'{"lifetime": "forever"}', 422, "lifetime"),
    ("POST", "/runs", b'{"preset": "hurricane"}', 422, "hurricane"),
    ("POST", "/runs", b'{"model": "kaimal", "preset": 3}', 422, "preset"),
    ("POST", "/runs", b'{"U_m_s": NaN}', 422, None),
    ("POST", "/sweeps", b'{"models": ["mann"]}', 422, None),
    ("POST", "/sweeps", b'{"models": ["mann"], "presets": ["neutral"], "speeds": [10], "seeds": [1], '
                        b'"preset_file": "/etc/passwd"}', 422, "preset_file"),
    # found with "lidar": "/path/on/the/server.json": the server opened and parsed a client-named file (its
    # keys came back in the 422), and "scheduler": the server probed a client-chosen host:port for 3 s
    ("POST", "/sweeps", _SWEEP_WITH("lidar", str(_SERVER_FILE)), 422, "lidar: not accepted"),
    ("POST", "/sweeps", _SWEEP_WITH("scheduler", "tcp://127.0.0.1:1"), 422, "scheduler: not accepted by the service "
     "(the server's own cluster"),
    ("POST", "/sweeps", _SWEEP_WITH("workers", 256), 422, "workers: not accepted"),  # was silently ignored
    ("POST", "/sweeps", _SWEEP_WITH("out", "/tmp/elsewhere"), 422, "out: not accepted"),  # was silently ignored
    ("GET", "/runs/../../etc/passwd", None, 404, None),
    ("GET", "/runs/%2e%2e%2f%2e%2e%2fetc%2fpasswd", None, 404, None),
    ("GET", "/runs/" + "0" * 24, None, 404, None),
    ("GET", "/runs/NOT-AN-ID", None, 404, None),
    ("GET", "/runs/" + "0" * 24 + "/store/zarr.json", None, 404, None),
    ("GET", "/runs/" + "0" * 24 + "/export?format=bts", None, 404, None),
    ("GET", "/runs/" + "0" * 24 + "/plots/..%2F..%2Frequest.json", None, 404, None),
    ("GET", "/nowhere", None, 404, None),
    # FastAPI's own parameter check: one line naming the parameter (was a list the page showed as [object Object])
    ("GET", "/runs?U=fast", None, 422, "query.U"),
    ("PUT", "/runs", b"{}", 405, None),
]


@pytest.mark.parametrize("method,path,raw,expected,mentions", BAD, ids=[f"{m} {p} {r!r}"[:60] for m, p, r, *_ in BAD])
def test_bad_requests(guarded, method, path, raw, expected, mentions):
    before = sorted(os.listdir(guarded.root / "runs"))
    status, _, out = guarded.call(method, path, raw=raw, headers=AUTH)
    assert status == expected, out
    if mentions is not None:
        assert isinstance(out["detail"], str) and mentions in out["detail"]
    assert guarded.call("GET", "/health")[0] == 200
    assert sorted(os.listdir(guarded.root / "runs")) == before  # nothing left behind


def test_store_paths_cannot_escape(guarded):
    status, _, out = guarded.call("POST", "/runs", _run(1), headers=AUTH)
    rid = guarded.wait(out["id"])["id"]
    assert guarded.call("GET", f"/runs/{rid}/store/zarr.json")[0] == 200
    for path in ("../request.json", "%2e%2e/request.json", "..%2frequest.json", "u/../../request.json",
                 ".hidden", "u/%00", "/etc/passwd", "%2fetc%2fpasswd"):
        assert guarded.call("GET", f"/runs/{rid}/store/{path}")[0] == 404, path
    assert guarded.call("GET", f"/runs/{rid}/export?format=exe")[0] == 422


def test_restart_after_kill_9(tmp_path):
    root = tmp_path / "root"
    srv = Server(root)
    try:
        done = srv.call("POST", "/runs", _run(7))[2]["id"]
        srv.wait(done)
        slow = srv.call("POST", "/runs", _run(8, SLOW_GRID))[2]["id"]
        srv.wait(slow, states=("running",), timeout_s=60)
    finally:
        srv.kill()  # SIGKILL mid-run
    assert not (root / "runs" / slow / "store.zarr").exists()
    srv = Server(root)
    try:
        assert srv.call("GET", f"/runs/{done}")[2]["status"] == "complete"
        assert srv.call("GET", "/health")[2]["computations"] == 1  # only the interrupted run is recomputed
        state = srv.call("GET", f"/runs/{slow}")[2]["status"]
        assert state in ("queued", "running", "complete")
        if state != "complete":
            assert srv.call("GET", f"/runs/{slow}/store/zarr.json")[0] == 404  # no partial store served
        srv.wait(slow, timeout_s=120)
        assert srv.call("GET", f"/runs/{slow}/store/zarr.json")[0] == 200
        # the status is complete once the store is published; the summary is the server's last write of the run
        deadline = time.monotonic() + 60
        while "summary" not in srv.call("GET", f"/runs/{slow}")[2] and time.monotonic() < deadline:
            time.sleep(0.1)
        leftovers = [p for p in os.listdir(root / "runs" / slow) if p.startswith(".")]
        assert leftovers == []
    finally:
        srv.kill()


@pytest.mark.parametrize("model", ["mann", "kaimal"])
def test_a_preset_request_builds_the_run_of_the_cli_and_the_sweep(model):
    # the service's request -> run path is the registry's, as `turbgen mann|kaimal --preset` and sweeps
    from turbgen.service.run_ids import build_run
    from turbgen.sweep.plan import build_run as sweep_run

    name, run, _ = build_run({"model": model, "preset": "stable", "U_m_s": 12.0, "seed": 4})
    assert name == model
    assert run.to_attrs() == sweep_run(model, "stable", 12.0, 4).to_attrs()


def test_a_complete_run_is_served_whatever_the_memory_budget(tmp_path):
    """Found by a walk-through: a run completed under one budget, resubmitted to a server restarted with a smaller
    --memory-budget, got 413 instead of its store. A complete run is served (200) without the budget check; a new
    run over the budget is still refused."""
    root = tmp_path / "root"
    first = Server(root)
    try:
        rid = first.call("POST", "/runs", _run(7, SLOW_GRID))[2]["id"]
        first.wait(rid, timeout_s=120)
    finally:
        first.kill()
    small = Server(root, "--memory-budget", "0.01")  # 10 MiB, the least allowed: below this run
    try:
        status, _, out = small.call("POST", "/runs", _run(7, SLOW_GRID))
        assert status == 200 and out["id"] == rid and out["submitted"] == "complete", (status, out)
        status, _, out = small.call("POST", "/runs", _run(8, SLOW_GRID))
        assert status == 413 and "--memory-budget" in out["detail"], (status, out)
    finally:
        small.kill()


@pytest.mark.parametrize("mode, warned", [(0o644, True), (0o600, False)])
def test_a_token_file_others_can_read_is_warned_about(tmp_path, mode, warned):
    root = tmp_path / "root"
    token_file = tmp_path / "token"
    token_file.write_text(TOKEN + "\n")
    token_file.chmod(mode)
    srv = Server(root, "--token-file", str(token_file))
    srv.kill()
    log = (tmp_path / "root.log").read_text()
    assert ("token file" in log and "readable by other users (chmod 600 it)" in log) == warned, log
