"""The service defects of issue 27 section 4: what a failed run's error shows, start-up clean-up of dead
processes' temporaries and the stencil cache's cap, DELETE during a validation, bounded derived computations,
exports with drop_below_ground, no dask HTTP servers, connection limits, and pages without external hosts."""

from __future__ import annotations

import os
import threading
import time

import pytest

from service_server import TINY_GRID, Server

TOKEN = "another-token-for-the-defect-tests"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


def _kaimal(seed, **extra):
    return {"model": "kaimal", "seed": seed, "U_m_s": 10.0, "grid": dict(TINY_GRID), **extra}


def _rid(body):
    from turbgen.service.run_ids import build_run, canonical_mapping, run_id

    model, run, constraints = build_run(body)
    return run_id(model, canonical_mapping(run, constraints))


@pytest.fixture(scope="module")
def token_server(tmp_path_factory):
    root = tmp_path_factory.mktemp("defects") / "root"
    token_file = root.parent / "token"
    token_file.write_text(TOKEN + "\n")
    token_file.chmod(0o600)
    srv = Server(root, "--token-file", str(token_file))
    yield srv
    srv.kill()


def test_a_failed_runs_error_shows_no_server_path_and_no_cli_advice(token_server):
    """Found by the service audit: GET /runs/<id> of a failed run showed the server's absolute --root (to anyone,
    also on a token server) and suggested `overwrite` / `out`, which a client cannot give."""
    body = _kaimal(21)
    rid = _rid(body)
    run_dir = token_server.root / "runs" / rid
    run_dir.mkdir(parents=True)
    (run_dir / "store.zarr").write_text("in the way")  # the writer refuses to replace it: the run fails
    assert token_server.call("POST", "/runs", body, headers=AUTH)[0] == 202
    state = token_server.wait(rid, states=("failed",), timeout_s=60)  # wait() stops on failed only when asked
    error = state["error"]
    assert f"/runs/{rid}/store is a file, not a turbgen store; it will not be replaced" in error, error
    for leak in (str(token_server.root), str(token_server.root.resolve()), "`out`", "overwrite", "catalog"):
        assert leak not in error, (leak, error)
    listed = {r["id"]: r for r in token_server.call("GET", "/runs")[2]["runs"]}
    assert listed[rid]["error"] == error


def test_a_disk_full_refusal_is_shown_without_the_root_or_out(tmp_path):
    # the writer's own refusal for a store larger than the free disk names the directory and suggests `out`
    from turbgen.errors import TurbgenError
    from turbgen.grid import Grid
    from turbgen.service.catalog import Catalog
    from turbgen.service.status import public_text
    from turbgen.store.writer import check_new_store

    catalog = Catalog(tmp_path / "root")
    rid = "0123456789abcdef01234567"
    (catalog.runs / rid).mkdir()
    huge = Grid(nt=2**24, dt_s=0.1, x_m=(0.0,), ny=2**14, nz=2**14, dy_m=1.0, dz_m=1.0)  # 16 EiB per component
    with pytest.raises(TurbgenError) as info:
        check_new_store(catalog.store_path(rid), huge)
    raw = str(info.value)
    assert str(catalog.root) in raw and "`out`" in raw  # what clients saw before
    shown = public_text(raw, catalog)
    assert str(catalog.root) not in shown and "`out`" not in shown and f"/runs/{rid}" in shown, shown


def test_a_conditioning_note_names_the_upload_and_the_service_s_fit_key(tmp_path):
    """The off-wind note of a constrained run, as the service shows it: the sensor named by its upload's id (not the
    server's file name of it) and the advice in the request's spelling, "fit": true (not the command's --fit)."""
    from turbgen.runs.constrain import off_wind_notes
    from turbgen.service.catalog import Catalog
    from turbgen.service.status import public_text

    up = "0123456789abcdef01234567"
    note = off_wind_notes([{"name": f"{up}.json:sonic 70.5 m:u", "direction_deg": 25.3}])[0]
    assert note.startswith(f"note: {up}.json:sonic 70.5 m: ") and "--fit (fit=True)" in note  # the command's
    shown = public_text(note, Catalog(tmp_path / "root"))
    assert shown.startswith(f"note: /constraints/{up}:sonic 70.5 m: after the file's mean wind"), shown
    assert "--fit" not in shown
    assert 'or replay with "fit": true, which does' in shown, shown
    # a name that only looks like an upload's inside a word or a path is left alone
    assert public_text(f"x{up}.json and /data/{up}.csv", Catalog(tmp_path / "root")) == f"x{up}.json and /data/{up}.csv"


def test_a_replay_is_fitted_once_at_submission_and_the_worker_takes_that_fit(tmp_path, monkeypatch):
    """Found by the replay review: the server fitted a replay at submission (its refusals are a 422) and the worker
    fitted it again, seconds each. The submission's fit now goes to the worker with the run; a run re-queued after a
    restart has none and is fitted in the worker (the served field equals the command's: test_service)."""
    from pathlib import Path

    from turbgen.runs import constrain, replay
    from turbgen.service.catalog import Catalog
    from turbgen.service.jobs import Jobs, execute
    from turbgen.service.routes.runs import _accept
    from turbgen.service.state import ServiceSettings, ServiceState

    submitted = []

    class Client:  # the worker's side is called below, by hand
        def submit(self, fn, *args, **kwargs):
            submitted.append(args)
            return type("Pending", (), {"add_done_callback": lambda self, f: None})()

    catalog = Catalog(tmp_path / "root")
    mast = Path(__file__).resolve().parents[2] / "examples" / "mast-fit.json"
    up = catalog.uploads.add("application/json", mast.read_bytes())[0]
    state = ServiceState(ServiceSettings(catalog.root, None, 2**34, 4), catalog, Jobs(catalog, Client(), 4))
    fits = []
    monkeypatch.setattr(replay, "fitted_inputs", lambda *a, **k: fits.append(a) or ("mapping", "files", "record"))
    grid = {"nt": 1024, "dt_s": 0.5, "ny": 16, "nz": 15, "dy_m": 3.0, "x_m": [0]}  # the mast inside it
    rid, how = _accept({"model": "mann", "constrain": [up], "fit": True, "hub_height_m": 88.5, "grid": grid}, state)
    assert how == "queued" and len(fits) == 1 and submitted[0][-1] == ("mapping", "files", "record")
    class Conditioned(Exception):  # the worker got past its fit: stop it there
        pass

    def conditioned(mapping, files, *rest):
        raise Conditioned(mapping, files)

    monkeypatch.setattr(constrain, "with_energy_from_data", conditioned)
    with pytest.raises(Conditioned) as worker:
        execute(*submitted[0])
    assert worker.value.args == ("mapping", "files") and len(fits) == 1  # the submission's fit, not a second one
    state.jobs.active.clear()
    state.jobs.resume()  # after a restart: no fit to hand over, the worker fits
    assert submitted[-1][-1] is None and len(fits) == 1


def test_a_published_store_is_complete_once_its_summary_is_written(tmp_path):
    """Found by a suite run under load (test_the_run_page_says_what_conditioning_did: KeyError 'summary'): the status
    said complete as soon as the store was published, before the worker's result (the summary: a replay's fitted
    values, the conditioning lines) was written, and a page loaded then never showed them. Until the summary is
    there the run is running with every chunk done; a run whose summary was never written (its server died in
    between) is complete without one."""
    import json

    import turbgen
    from turbgen.service.catalog import Catalog
    from turbgen.service.jobs import Jobs
    from turbgen.service.run_ids import build_run, canonical_mapping, run_id
    from turbgen.service.status import run_status

    class Client:  # a worker that has not answered yet
        def submit(self, *args, **kwargs):
            return type("Pending", (), {"add_done_callback": lambda self, f: None})()

    catalog = Catalog(tmp_path / "root")
    jobs = Jobs(catalog, Client(), max_queue=2)
    model, run, c = build_run({"model": "mann", "seed": 1, "U_m_s": 10.0, "grid": dict(TINY_GRID)})
    rid = run_id(model, canonical_mapping(run, c))
    assert jobs.submit(rid, model, run) == "queued"
    turbgen.mann(nt=16, ny=4, nz=4, planes=[0], pad_yz=1, out=catalog.store_path(rid))  # the worker published
    s = run_status(catalog, jobs, rid)
    assert s["status"] == "running" and s["progress"]["chunks_done"] == s["progress"]["chunks_total"], s
    (catalog.run_dir(rid) / "summary.json").write_text(json.dumps({"seconds": 1.0}))
    s = run_status(catalog, jobs, rid)
    assert s["status"] == "complete" and s["summary"] == {"seconds": 1.0}, s
    (catalog.run_dir(rid) / "summary.json").unlink()
    jobs.active.clear()  # the server restarted: nothing will write the summary
    assert run_status(catalog, jobs, rid)["status"] == "complete"


def _dead_pid() -> int:
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid  # reaped: no process has it (until the kernel reuses it, far away)


def test_start_up_removes_dead_processes_temporaries_and_caps_the_stencil_cache(tmp_path):
    """Found by the service audit: a kill -9 during a stencil build left a 385 MB .mann-stencil-*.npy.tmp-* forever,
    kills during validation/export left runs/<id>/.tmp-validation-* that start-up never removed; the stencil cache
    had no size cap."""
    root = tmp_path / "root"
    rid = "0123456789abcdef01234567"
    run_dir = root / "runs" / rid
    (run_dir / "exports").mkdir(parents=True)
    stencils = root / "stencils"
    stencils.mkdir()
    dead, alive = _dead_pid(), os.getpid()
    garbage = [stencils / f".mann-stencil-abc.npy.tmp-{dead}-0badc0de", run_dir / ".tmp-validation-k3j4h5",
               run_dir / "exports" / ".tmp-x8y9z0", run_dir / f".summary.json.tmp-{dead}-01234567",
               root / "runs" / f".{rid}.tmp-{dead}-89abcdef", root / "work" / f".{rid}-validation.tmp-{dead}-aa"]
    for p in garbage:
        p.parent.mkdir(parents=True, exist_ok=True)
        (p / "report.json").parent.mkdir(parents=True) if "validation" in p.name else p.write_bytes(b"x" * 1000)
    live = stencils / f".mann-stencil-def.npy.tmp-{alive}-0badc0de"  # a writer that still runs: kept
    live.write_bytes(b"x")
    entries = [stencils / f"mann-stencil-{k}.npy" for k in ("old", "mid", "new")]
    for age, p in zip((300, 200, 100), entries):
        p.write_bytes(b"s" * 2**20)
        os.utime(p, (time.time() - age,) * 2)
    srv = Server(root, "--stencil-cache-size", "2.5MiB")
    srv.kill()
    left = [p for p in garbage if p.exists()]
    assert left == [], left
    assert live.exists()
    assert [p.exists() for p in entries] == [False, True, True]  # the least recently used evicted down to the cap
    log = (tmp_path / "root.log").read_text()
    assert f"{len(garbage) + 1} temporary file(s)" in log, log


def test_stencil_cache_trim_keeps_the_most_recent_entry(tmp_path):
    from turbgen.service.cleanup import trim_stencil_cache

    entries = [tmp_path / f"mann-stencil-{k}.npy" for k in "abc"]
    for age, p in zip((30, 20, 10), entries):
        p.write_bytes(b"s" * 1000)
        os.utime(p, (time.time() - age,) * 2)
    assert trim_stencil_cache(tmp_path, 2500) == entries[:1]
    assert trim_stencil_cache(tmp_path, 10) == entries[1:2]  # the newest stays even when alone over the cap
    assert trim_stencil_cache(tmp_path, None) == [] and entries[2].exists()


class _SlowValidation:
    """Stands in for turbgen.validation.validate: each call blocks until ``release`` (at most 60 s) and counts."""

    def __init__(self):
        self.release = threading.Event()
        self.started = threading.Semaphore(0)
        self.calls = 0

    def __call__(self, store):
        self.calls += 1
        self.started.release()
        assert self.release.wait(60)
        return _Report()


class _Report:
    def plots(self, directory):
        directory.mkdir(parents=True, exist_ok=True)  # as ValidationReport.plots
        (directory / "spectrum_u.png").write_bytes(b"\x89PNG fake")

    def to_dict(self):
        return {"passed": True}


@pytest.fixture
def slow_server(tmp_path, monkeypatch):
    """An in-process server with one complete Kaimal run whose validation blocks until released."""
    import turbgen.validation
    from inprocess_server import InProcessServer

    fake = _SlowValidation()
    monkeypatch.setattr(turbgen.validation, "validate", fake)
    srv = InProcessServer(tmp_path / "root", derived_running=1, derived_waiting=1)
    try:
        rid = srv.call("POST", "/runs", _kaimal(5))[2]["id"]
        srv.wait(rid)
        yield srv, rid, fake
    finally:
        fake.release.set()
        srv.stop()


def _in_thread(fn, *args, **kw):
    out = {}
    t = threading.Thread(target=lambda: out.setdefault("result", fn(*args, **kw)), daemon=True)
    t.start()
    return t, out


def test_a_run_deleted_during_its_validation_stays_deleted(slow_server):
    """Found by the service audit: DELETE /runs/<id> while its validation computed; the validation then recreated
    runs/<id>/validation/, invisible to the API and never removed."""
    srv, rid, fake = slow_server
    thread, out = _in_thread(srv.call, "GET", f"/runs/{rid}/validation", timeout_s=90)
    assert fake.started.acquire(timeout=30)  # the validation computes
    assert srv.call("DELETE", f"/runs/{rid}")[0] == 200
    fake.release.set()
    thread.join(60)
    status, _, body = out["result"]
    assert status == 404 and "deleted" in body["detail"], (status, body)
    assert not (srv.root / "runs" / rid).exists()
    assert os.listdir(srv.root / "work") == []


def test_concurrent_uncached_validations_are_bounded_and_health_answers(slow_server):
    """Found by the service audit: 42 concurrent uncached GET .../validation took every worker thread and /health
    answered after 14 s. Now at most running + waiting (here 1 + 1) are admitted, the others get 503 with
    Retry-After at once, and /health answers meanwhile."""
    srv, rid, fake = slow_server
    requests = [_in_thread(srv.call, "GET", f"/runs/{rid}/validation", timeout_s=90) for _ in range(6)]
    assert fake.started.acquire(timeout=30)
    deadline = time.monotonic() + 30
    while sum("result" in out for _, out in requests) < 4 and time.monotonic() < deadline:
        time.sleep(0.05)
    refused = [out["result"] for _, out in requests if "result" in out]
    assert len(refused) == 4, refused  # 6 requests - 1 computing - 1 waiting
    assert all(s == 503 and int(h["retry-after"]) > 0 for s, h, _ in refused), refused
    t0 = time.monotonic()
    assert srv.call("GET", "/health", timeout_s=5)[0] == 200
    assert time.monotonic() - t0 < 2.0  # the event loop answers while the validation holds its thread
    fake.release.set()
    for thread, _ in requests:
        thread.join(60)
    answers = sorted(out["result"][0] for _, out in requests)
    assert answers == [200, 200, 503, 503, 503, 503] and fake.calls == 1  # the waiting one reused the result


def test_a_low_hub_height_run_exports_with_drop_below_ground(tmp_path):
    """Found by the service audit: a run with a low hub height could never be exported (422 '... pass
    drop_below_ground', which the endpoint did not take)."""
    from inprocess_server import InProcessServer

    srv = InProcessServer(tmp_path / "root")
    try:
        rid = srv.call("POST", "/runs", _kaimal(6, hub_height_m=10.0))[2]["id"]  # 8 rows 5 m apart: 2 below ground
        srv.wait(rid)
        status, _, out = srv.call("GET", f"/runs/{rid}/export?format=bts")
        assert status == 422 and "?drop_below_ground=true" in out["detail"] and str(srv.root) not in out["detail"]
        status, _, data = srv.call("GET", f"/runs/{rid}/export?format=bts&drop_below_ground=true")
        assert status == 200, data
        bts = tmp_path / "out.bts"
        bts.write_bytes(data)
        from turbgen.exporters.bts import read_bts

        z = read_bts(bts)["z"]
        assert z.min() > 0 and len(z) == TINY_GRID["nz"] - 2, z
    finally:
        srv.stop()


def test_the_server_listens_on_its_own_port_only(tmp_path):
    """Found by the service audit: each server opened two more loopback ports (the dask scheduler's and worker's
    HTTP servers) answering /json/identity.json and /metrics without the Host check."""
    import psutil

    srv = Server(tmp_path / "root")
    try:
        assert srv.call("POST", "/runs", _kaimal(8))[0] == 202  # the cluster has worked
        conns = psutil.Process(srv.proc.pid).net_connections(kind="inet")
        listening = sorted({c.laddr.port for c in conns if c.status == psutil.CONN_LISTEN})
        assert listening == [srv.port], listening
    finally:
        srv.kill()


def test_half_open_connections_are_closed_within_the_head_deadline(tmp_path):
    """Found by the service audit: 2000 half-open connections (nothing or half a request head sent) were held over
    10 s. Now a connection without a complete request head is closed within one to two head deadlines (5 s each),
    one whose body trickles is answered 408 after BODY_TIMEOUT_S, while complete requests are answered."""
    import socket

    from turbgen.service.bodies import BODY_TIMEOUT_S
    from turbgen.service.server import HEADER_TIMEOUT_S

    srv = Server(tmp_path / "root")
    socks = []
    try:
        t0 = time.monotonic()
        for i in range(40):
            s = socket.create_connection(("127.0.0.1", srv.port), timeout=15)
            if i % 2:
                s.sendall(b"GET /health HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")  # half a head, never finished
            socks.append(s)
        trickle = socket.create_connection(("127.0.0.1", srv.port), timeout=15)  # a body that never completes
        trickle.sendall(b"POST /runs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                        b"Content-Length: 100\r\n\r\n{")
        socks.append(trickle)
        assert srv.call("GET", "/health", timeout_s=5)[0] == 200  # others are served meanwhile
        for s in socks[:-1]:
            assert s.recv(1024) == b""  # closed by the server (a timeout here raises)
        elapsed = time.monotonic() - t0
        assert elapsed < 2 * HEADER_TIMEOUT_S + 1.0, elapsed  # the audit saw > 10 s with no end
        assert trickle.recv(1024).startswith(b"HTTP/1.1 408 ")  # after BODY_TIMEOUT_S
        assert time.monotonic() - t0 < BODY_TIMEOUT_S + 3.0
    finally:
        for s in socks:
            s.close()
        srv.kill()


def test_no_page_loads_anything_from_another_host(token_server):
    """Found by the service audit: /docs loaded Swagger UI from a CDN (offline it rendered nothing)."""
    import re

    external = re.compile(r"""(?:src|href|action)\s*=\s*["']?\s*(?:[a-z][a-z0-9+.-]*:)?//"""  # another host
                          r"""|@import|url\(\s*["']?(?:https?:)?//""", re.IGNORECASE)  # fmt: skip
    for path in ("/", "/docs"):
        status, hdrs, page = token_server.call("GET", path)
        text = page.decode()
        assert status == 200 and hdrs["content-type"].startswith("text/html"), (path, status)
        assert not external.search(text) and "cdn" not in text.lower(), (path, external.search(text))
    docs = token_server.call("GET", "/docs")[2].decode()
    assert 'href="/openapi.json"' in docs and "GET /runs/{rid}/export" in docs and "drop_below_ground" in docs
    assert token_server.call("GET", "/redoc")[0] == 404  # FastAPI's ReDoc page loads from a CDN too: off
    assert token_server.call("GET", "/openapi.json")[0] == 200


def test_a_stencil_cache_hit_renews_the_entry_for_the_lru_cap(tmp_path):
    # the cap evicts by modification time: a hit must count as a use, or the most used stencil goes first
    from turbgen.runs.stencil_cache import cached_stencil
    from turbgen.synthesis.mann_stencil import BoxShape
    from turbgen.theory.params import MannParams

    box = BoxShape(nt=16, dx_m=4.0, nyp=6, nzp=6, dy_m=6.0, dz_m=5.0)
    params = MannParams(ae=0.3, length_scale_m=30.0, gamma=3.2, evo_time_s=20.0)
    cached_stencil(params, box, tmp_path, energy="unit")
    (entry,) = tmp_path.glob("mann-stencil-*.npy")
    os.utime(entry, (1e9, 1e9))  # used long ago
    cached_stencil(params, box, tmp_path, energy="unit")  # a hit
    assert entry.stat().st_mtime > time.time() - 60
