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

    model, run = build_run(body)
    return run_id(model, canonical_mapping(run))


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
    assert f"/runs/{rid}/store already exists" in error, error
    for leak in (str(token_server.root), str(token_server.root.resolve()), "`out`", "overwrite"):
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
