"""`turbgen serve` end to end: a real server process on a loopback port, spoken to over HTTP."""

from __future__ import annotations

import io
import shutil
import json
import os
import subprocess
import sys
import threading
import time
import zipfile
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from service_server import TINY_GRID, Server

from turbgen.exporters import export_store, read_bts, read_hawc2
from turbgen.service.run_ids import canonical_mapping, run_from_canonical
from turbgen.store import open_store

CHROMEDRIVER = shutil.which("chromedriver")
CHROMIUM = shutil.which("chromium")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    srv = Server(tmp_path_factory.mktemp("serve") / "root", "--workers", "2")
    yield srv
    srv.kill()


@pytest.fixture
def browser(tmp_path):
    if CHROMEDRIVER is None or CHROMIUM is None:
        # required in CI (.ci/run installs chromium and sets CI=true); a fresh machine without a browser skips it,
        # with the reason shown by pytest's -ra summary, so the README's test command passes there
        missing = ("the page test needs chromium and chromedriver (apt-get install chromium chromium-driver; "
                   ".ci/run installs them)")  # fmt: skip
        if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
            pytest.fail(missing)
        pytest.skip(missing)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 f"--user-data-dir={tmp_path / 'chromium-profile'}"):  # fmt: skip
        opts.add_argument(flag)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    driver.set_page_load_timeout(30)
    yield driver
    driver.quit()


def _until(condition, timeout_s: float, what: str):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.2)
    raise TimeoutError(what)


def _config(seed, model="mann", **extra):
    return {"model": model, "seed": seed, "U_m_s": 10.0, "grid": dict(TINY_GRID), **extra}


def _cli(args, cwd):
    cmd = [sys.executable, "-c", "from turbgen.cli import main; main()", *args]
    done = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done


def test_cross_site_posts_are_refused(server):
    # found by POSTing a run as text/plain with an Origin of another site: 200/202, so any web page the
    # user visits could queue runs on a token-less loopback server (a form or a no-cors fetch needs no
    # CORS preflight; application/json does, and the server grants none)
    import http.client

    run = json.dumps({"model": "mann", "seed": 987654, "U_m_s": 10.0, "grid": dict(TINY_GRID)})
    for ctype in ("text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x"):
        for path in ("/runs", "/sweeps"):
            conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
            conn.request("POST", path, run, headers={"Content-Type": ctype, "Origin": "http://evil.example"})
            r = conn.getresponse()
            out = json.loads(r.read())
            conn.close()
            assert r.status == 415 and "application/json" in out["detail"], (ctype, path, r.status, out)
    assert server.call("GET", "/runs?seed=987654")[2]["runs"] == []


@pytest.mark.parametrize("depth", [30000, 40])
def test_deeply_nested_json_is_a_422_not_a_500(server, depth):
    # found by POSTing 30000 nested arrays (60 KB, under the body limit): json.loads recursed past Python's limit,
    # a 500; 40 levels parse but are refused before the schema validation recurses into them
    import http.client

    nested = "[" * depth + "]" * depth
    body = json.dumps({"model": "mann", "grid": {"x_m": nested}}).replace(f'"{nested}"', nested)
    for path in ("/runs", "/sweeps"):
        conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
        conn.request("POST", path, body, headers={"Content-Type": "application/json"})
        r = conn.getresponse()
        out = json.loads(r.read())
        conn.close()
        assert r.status == 422 and "nested deeper than 32 levels" in out["detail"], (path, r.status, out)


def test_loopback_server_answers_only_loopback_host_names(server):
    # found by sending Host: evil.example to the 127.0.0.1 server: 200 (and POST 202), so a page whose
    # name is re-bound to 127.0.0.1 (DNS rebinding) is same-origin with the server and can submit or
    # delete runs and read the catalog
    import http.client

    for host, expected in ((f"evil.example:{server.port}", 400), ("evil.example", 400),
                           (f"localhost:{server.port}", 200), (f"127.0.0.1:{server.port}", 200)):  # fmt: skip
        conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
        conn.request("GET", "/runs", headers={"Host": host})
        r = conn.getresponse()
        r.read()
        conn.close()
        assert r.status == expected, (host, r.status)


@pytest.mark.parametrize("model", ["mann", "kaimal"])
def test_served_store_is_bit_identical_to_the_cli(server, tmp_path, model):
    cfg = _config(11, model)
    status, _, out = server.call("POST", "/runs", cfg)
    assert status == 202 and out["submitted"] == "queued"
    s = server.wait(out["id"])
    assert s["model"] == model and s["parameters"]["seed"] == 11 and s["progress"]["chunks_done"] == 6
    run_cfg = {k: v for k, v in cfg.items() if k != "model"}
    (tmp_path / "run.json").write_text(json.dumps(run_cfg))
    _cli([model, "--config", "run.json", "--out", "cli.zarr"], tmp_path)
    served, local = open_store(server.root / "runs" / out["id"] / "store.zarr"), open_store(tmp_path / "cli.zarr")
    for c in "uvw":
        np.testing.assert_array_equal(served.array(c)[...], local.array(c)[...])


def test_concurrent_duplicates_compute_once(server):
    cfg = _config(21)
    before = server.call("GET", "/health")[2]["computations"]
    results = []

    def submit():
        results.append(server.call("POST", "/runs", cfg))

    threads = [threading.Thread(target=submit) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert sorted(r[2]["submitted"] for r in results) in (["joined", "queued"], ["complete", "queued"])
    (rid,) = {r[2]["id"] for r in results}
    server.wait(rid)
    again = server.call("POST", "/runs", cfg)
    assert again[0] == 200 and again[2] == {**again[2], "id": rid, "submitted": "complete"}
    assert server.call("GET", "/health")[2]["computations"] == before + 1
    listed = server.call("GET", "/runs?seed=21")[2]["runs"]
    assert [r["id"] for r in listed] == [rid]
    # a different seed is a different run
    assert server.call("POST", "/runs", _config(22))[2]["id"] != rid


def test_remote_open_zarr_equals_local_store(server):
    rid = server.call("POST", "/runs", _config(31))[2]["id"]
    server.wait(rid)
    remote = xr.open_zarr(f"{server.url}/runs/{rid}/store")
    local = xr.open_zarr(server.root / "runs" / rid / "store.zarr")
    for c in "uvw":
        np.testing.assert_array_equal(remote[c].values, local[c].values)
    assert remote.attrs["seed"] == 31


def test_exports_download_and_read_back(server, tmp_path):
    rid = server.call("POST", "/runs", _config(41))[2]["id"]
    server.wait(rid)
    store = server.root / "runs" / rid / "store.zarr"
    status, hdrs, payload = server.call("GET", f"/runs/{rid}/export?format=bts")
    assert status == 200
    (tmp_path / "served.bts").write_bytes(payload)
    export_store(store, "bts", tmp_path / "local.bts")
    got, want = read_bts(tmp_path / "served.bts"), read_bts(tmp_path / "local.bts")
    for key in ("u", "v", "w"):
        np.testing.assert_array_equal(got[key], want[key])
    assert server.call("GET", f"/runs/{rid}/export?format=bts")[2] == payload  # cached, same bytes
    # the exports name the store as the API does, never by the server's catalog path
    assert f"/runs/{rid}/store ".encode() in payload and str(server.root).encode() not in payload
    status, _, h5_bytes = server.call("GET", f"/runs/{rid}/export?format=hdf5")
    (tmp_path / "served.h5").write_bytes(h5_bytes)
    with h5py.File(tmp_path / "served.h5", "r") as h5:
        assert status == 200 and h5.attrs["source_store"] == f"/runs/{rid}/store"
    status, _, payload = server.call("GET", f"/runs/{rid}/export?format=hawc2")
    assert status == 200
    zipfile.ZipFile(io.BytesIO(payload)).extractall(tmp_path / "h2")
    export_store(store, "hawc2", tmp_path / "local")
    assert sorted(os.listdir(tmp_path / "h2")) == [f"{rid}_{c}.bin" for c in "uvw"]
    got, want = read_hawc2(tmp_path / "h2" / rid, (256, 8, 8), 10.0), read_hawc2(tmp_path / "local", (256, 8, 8), 10.0)
    for c in "uvw":
        np.testing.assert_array_equal(got[c], want[c])


def test_page_submits_a_run_and_shows_its_plots(server, browser):
    """Real headless chromium: the form submits a run, the catalog shows it complete, its plots load."""
    from selenium.webdriver.common.by import By

    srv = server  # the module server: this run is validated once for both tests
    browser.get(srv.url + "/")
    assert "turbgen serve" in browser.title
    seed = browser.find_element(By.NAME, "seed")
    seed.clear()
    seed.send_keys("51")  # the run test_validation_json_and_png reads (validated once)
    browser.find_element(By.ID, "submit-button").click()
    msg = _until(lambda: browser.find_element(By.ID, "message").text, 30, "no submit message")
    assert msg.startswith("submitted "), msg
    rid = msg.split()[1]
    row = f"#run-{rid} .status"
    # the catalog table is re-rendered every second: read and click through the live DOM, not stale handles
    text = "const e = document.querySelector(arguments[0]); return e ? e.textContent : null;"
    _until(lambda: browser.execute_script(text, row) == "complete", 60, "run not complete")
    assert srv.call("GET", f"/runs/{rid}")[2]["parameters"]["seed"] == 51
    browser.execute_script("document.querySelector(arguments[0]).click();", f"#run-{rid} .show-plots")
    imgs = _until(lambda: browser.find_elements(By.CSS_SELECTOR, "#plots img.plot"), 120, "no plots shown")
    # every image loaded and decoded (naturalWidth > 0 only for a real PNG)
    _until(lambda: all(browser.execute_script("return arguments[0].complete && arguments[0].naturalWidth", i)
                       for i in imgs), 30, "plots did not load")  # fmt: skip
    assert "Validation of " + rid in browser.find_element(By.ID, "plots").text


def test_validation_json_and_png(server):
    rid = server.call("POST", "/runs", _config(51))[2]["id"]
    server.wait(rid)
    status, _, v = server.call("GET", f"/runs/{rid}/validation", timeout_s=60)
    assert status == 200 and v["report"]["model"] == "mann" and isinstance(v["report"]["passed"], bool)
    assert v["plots"]
    status, hdrs, png = server.call("GET", v["plots"][0])
    assert status == 200 and hdrs["content-type"] == "image/png" and png[:8] == b"\x89PNG\r\n\x1a\n"
    assert server.call("GET", f"/runs/{rid}")[2]["validation"]["passed"] == v["report"]["passed"]


def test_sweep_and_delete(server):
    sweep = {"models": ["mann"], "presets": ["neutral"], "speeds": [10.0], "seeds": [1, 2],
             "mann": {"nt": 256, "ny": 8, "nz": 8, "planes": [0.0, 50.0]}}
    status, _, out = server.call("POST", "/sweeps", sweep)
    assert status == 202, out
    ids = [r["id"] for r in out["runs"]]
    assert len(set(ids)) == 2
    for rid in ids:
        server.wait(rid)
    listed = server.call("GET", "/runs?preset=neutral&U=10")[2]["runs"]
    assert sorted(r["id"] for r in listed) == sorted(ids)
    assert server.call("DELETE", f"/runs/{ids[0]}")[0] == 200
    assert server.call("GET", f"/runs/{ids[0]}")[0] == 404
    assert not (server.root / "runs" / ids[0]).exists()


def test_lidar_on_a_served_run(server):
    """GET /runs/{id}/lidar: the virtual lidar of `turbgen lidar` on a served store (presets only)."""
    cfg = {"model": "mann", "seed": 61, "U_m_s": 16.0, "grid": {"nt": 512, "ny": 32, "nz": 32}}  # 11 default planes
    rid = server.call("POST", "/runs", cfg)[2]["id"]
    server.wait(rid)
    status, _, body = server.call("GET", f"/runs/{rid}/lidar?lidar=nacelle-4beam", timeout_s=120)
    assert status == 200, body
    rep = body["report"]
    assert rep["store"] == f"/runs/{rid}/store" and 0.005 < rep["theory"]["k05_rad_m"] < 0.1
    assert isinstance(rep["verdict"]["passed"], bool)
    assert server.call("GET", f"/runs/{rid}/lidar?lidar=../../etc/passwd")[0] == 422
    tiny = server.call("POST", "/runs", _config(62))[2]["id"]  # two planes: not the lidar's gates
    server.wait(tiny)
    status, _, body = server.call("GET", f"/runs/{tiny}/lidar", timeout_s=60)
    assert status == 422 and "lidar" in body["detail"] and "pytest-of" not in body["detail"]  # no server path


MAST = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "mast.json")
SMALL_RUN = {"seed": 2, "U_m_s": 12.0, "pad_yz": 1, "grid": {"nt": 64, "ny": 6, "nz": 6, "dy_m": 8.0, "x_m": [0, 40]}}


def _upload(server, data: bytes, ctype: str):
    return server.call("POST", "/constraints", raw=data, headers={"Content-Type": ctype})


def test_constrained_run_from_an_upload_is_the_cli_field(server, tmp_path):
    """POST /constraints keeps the content (same bytes, same id); a run naming its id is `turbgen mann --constrain
    FILE` to the bit, and its run id depends on the data."""
    data = open(MAST, "rb").read()
    status, _, up = _upload(server, data, "application/json")
    assert status == 201 and up["kind"] == "point series" and up["series"] == 2 and up["values"] == 128, up
    status, _, again = _upload(server, data, "application/json")
    assert status == 200 and again == up
    assert server.call("GET", f"/constraints/{up['id']}")[2] == up
    cfg = {"model": "mann", **SMALL_RUN, "constrain": [up["id"]], "noise_m_s": 0.1}
    status, _, out = server.call("POST", "/runs", cfg)
    assert status == 202, out
    s = server.wait(out["id"], timeout_s=120)
    assert s["parameters"]["constrain"] == [up["id"]] and s["parameters"]["noise_m_s"] == 0.1
    unconstrained = server.call("POST", "/runs", {"model": "mann", **SMALL_RUN})[2]["id"]
    other = _upload(server, data.replace(b'"noise_m_s": 0.05', b'"noise_m_s": 0.06'), "application/json")[2]["id"]
    assert len({out["id"], unconstrained, server.call("POST", "/runs", {**cfg, "constrain": [other]})[2]["id"]}) == 3
    (tmp_path / "run.json").write_text(json.dumps(SMALL_RUN))
    _cli(["mann", "--config", "run.json", "--constrain", os.path.abspath(MAST), "--noise", "0.1", "--out", "cli.zarr"],
         tmp_path)
    served, local = open_store(server.root / "runs" / out["id"] / "store.zarr"), open_store(tmp_path / "cli.zarr")
    for c in "uvw":
        np.testing.assert_array_equal(served.array(c)[...], local.array(c)[...])
    assert served.attrs["constraints"]["residual_max_m_s"] == local.attrs["constraints"]["residual_max_m_s"]
    sweep = {"models": ["mann"], "presets": ["neutral"], "speeds": [12], "seeds": [5], "constrain": [up["id"]],
             "grid": {"nt": 64, "ny": 6, "nz": 6, "dy": 8.0, "planes": [0, 40]}}  # fmt: skip
    status, _, sw = server.call("POST", "/sweeps", sweep)
    assert status == 202, sw
    s = server.wait(sw["runs"][0]["id"], timeout_s=120)
    assert s["parameters"]["constrain"] == [up["id"]] and "constraints" in open_store(
        server.root / "runs" / sw["runs"][0]["id"] / "store.zarr").attrs


def test_a_replay_from_an_upload_is_the_cli_field(server, tmp_path):
    """A run with ``fit`` on an uploaded mast is `turbgen mann --constrain FILE --fit` to the bit (the fit in the
    worker): U, L, Gamma and ae the fitted ones in its status; the keys the fit sets, a preset, what the fit refuses,
    and fit without constrain or in a sweep refused (422) before anything is queued."""
    mast = Path(__file__).resolve().parents[2] / "examples" / "mast-fit.json"
    up = _upload(server, mast.read_bytes(), "application/json")[2]["id"]
    grid = {"nt": 1024, "dt_s": 0.5, "ny": 16, "nz": 15, "dy_m": 3.0, "x_m": [0]}
    cfg = {"model": "mann", "constrain": [up], "fit": True, "hub_height_m": 88.5, "evo_time_s": None, "grid": grid}
    status, _, out = server.call("POST", "/runs", cfg)
    assert status == 202, out
    s = server.wait(out["id"], timeout_s=180)
    done = _cli(["mann", "--constrain", str(mast), "--fit", "--hub-height", "88.5", "--evo", "frozen", "--nt", "1024",
                 "--dt", "0.5", "--ny", "16", "--nz", "15", "--dy", "3", "--planes", "0", "--out", "cli.zarr"], tmp_path)
    # the status (and the run page) has the command's lines about the fit and the conditioning, the paths public
    lines, printed = s["summary"]["conditioning"], done.stdout + done.stderr
    assert lines[0].startswith(f"fitted to /constraints/{up}: L ") and str(server.root) not in " ".join(lines), lines
    assert f"samples from /constraints/{up};" in lines[len(lines) - 3], lines
    assert all(t in printed for t in lines if up not in t) and len([t for t in lines if up not in t]) >= 4, lines
    served, local = open_store(server.root / "runs" / out["id"] / "store.zarr"), open_store(tmp_path / "cli.zarr")
    for c in "uvw":
        np.testing.assert_array_equal(served.array(c)[...], local.array(c)[...])
    assert served.attrs["fit"]["run"] == local.attrs["fit"]["run"]
    fitted = local.attrs["fit"]["run"]
    assert {k: s["parameters"][k] for k in fitted} == fitted and s["parameters"]["fit"] is True
    assert server.call("POST", "/runs", cfg)[2] == {**out, "submitted": "complete"}  # the same id: served
    recorded = json.loads((server.root / "runs" / out["id"] / "request.json").read_text())["run"]
    assert recorded["fit"] == {"given": ["evo_time_s"]} and "length_scale_m" not in recorded
    assert canonical_mapping(*run_from_canonical("mann", recorded)) == recorded  # re-queued after a restart as it was
    for body, detail in (({**cfg, "length_scale_m": 30.0}, 'L with "fit": true: the fit sets L, gamma and '),
                         ({**cfg, "preset": "neutral"}, "preset with fit: the fit sets L, gamma and the energy level"),
                         ({k: v for k, v in cfg.items() if k != "constrain"}, "fit (--fit) needs constrain"),
                         ({**cfg, "factor1": 0.8}, "--fit with factor1 = 0.8: the fit's tables hold the lifetime")):
        status, _, refused = server.call("POST", "/runs", body)
        assert status == 422 and refused["detail"].startswith(detail), refused
    sweep = {"models": ["mann"], "presets": ["neutral"], "speeds": [12], "seeds": [5], "constrain": [up], "fit": True}
    status, _, refused = server.call("POST", "/sweeps", sweep)
    assert status == 422 and refused["detail"].startswith("fit: not accepted by the service (a sweep's presets")


def _los_csv(header: str, n_gates: int = 10) -> bytes:
    rows = ["time_s,beam,gate,v_los_m_s"] + [f"{s + 0.25 * b},{b},{g},{0.1 * g}" for s in range(2) for b in range(4)
                                             for g in range(n_gates)]  # fmt: skip
    return (header + "\n".join(rows) + "\n").encode()


def test_uploads_that_name_files_or_are_malformed_are_refused(server):
    """The service opens no path a client names: not in a run's or a sweep's constrain, not through an upload's
    lidar, mean history or table profile; each refusal is one line, 4xx."""
    status, _, up = _upload(server, _los_csv("# lidar = nacelle-4beam\n# U_m_s = 12\n"), "text/csv")
    assert status == 201 and up["kind"] == "line of sight" and up["series"] == 40 and up["values"] == 80, up
    sonic = b"# sensor s = x_m=0, y_m=0, z_m=0\ntime_s,s:u_m_s,s:w_m_s\n0,0.1,0.2\n0.5,,0.1\n"  # a point-series CSV
    status, _, points = _upload(server, sonic, "text/csv")
    assert status == 201 and points["kind"] == "point series" and points["series"] == 2 and points["values"] == 3
    assert server.call("GET", f"/constraints/{points['id']}")[2] == points  # read back from the kept file
    kept = sorted(os.listdir(server.root / "constraints"))
    secret = "# lidar = nacelle-4beam\n# U_m_s = 12\n"
    total = secret + "# total_wind = true\n"
    refused = [
        (_los_csv("# lidar = my.toml\n# U_m_s = 12\n"), "text/csv", 422, "lidar = 'my.toml' must be a preset"),
        (_los_csv(total + "# mean_history = /etc/hosts\n"), "text/csv", 422, "mean_history names"),
        (_los_csv(total + "# profile = table:/etc/hosts\n"), "text/csv", 422, "names a file"),
        (_los_csv(secret, n_gates=9), "text/csv", 422, "gate"),
        (b"# total_wind = true\n# mean_history = /etc/hosts\n" + sonic, "text/csv", 422, "mean_history names a file"),
        (b'{"mean_wind": {"mean_history": "/etc/hosts"}}', "application/json", 422, "mean_history names a file"),
        (b"[1, 2", "application/json", 422, "not valid JSON"),
        (b"time_s\n", "text/plain", 415, "Content-Type must be one of application/json, text/csv"),
    ]
    for data, ctype, code, match in refused:
        status, _, out = _upload(server, data, ctype)
        assert status == code and match in out["detail"] and "\n" not in out["detail"], (match, status, out)
    assert sorted(os.listdir(server.root / "constraints")) == kept  # nothing written for a refused upload
    for path, body in (("/runs", {"model": "mann", **SMALL_RUN, "constrain": ["/etc/hosts"]}),
                       ("/sweeps", {"models": ["mann"], "presets": ["neutral"], "speeds": [12], "seeds": [1],
                                    "constrain": ["/etc/hosts"]}),
                       ("/runs", {"model": "mann", **SMALL_RUN, "constrain": ["0" * 24]})):  # fmt: skip
        status, _, out = server.call("POST", path, body)
        assert status == 422 and "uploaded measurements" in out["detail"], (path, out)
    assert server.call("GET", "/constraints/" + "0" * 24)[0] == 404
    assert server.call("DELETE", f"/constraints/{up['id']}")[2] == {"id": up["id"], "deleted": True}
    assert server.call("GET", f"/constraints/{up['id']}")[0] == 404
    assert server.call("DELETE", f"/constraints/{up['id']}")[0] == 404
    mast = _upload(server, open(MAST, "rb").read(), "application/json")[2]["id"]
    off = {"model": "mann", **SMALL_RUN, "grid": {**SMALL_RUN["grid"], "x_m": [20, 40]}, "constrain": [mast]}
    status, _, out = server.call("POST", "/runs", off)  # the sonic at x = 0: off the field, refused at submission
    assert status == 422 and f"/constraints/{mast}" in out["detail"] and str(server.root) not in out["detail"], out
    big = {"model": "mann", **SMALL_RUN, "grid": {"nt": 65536, "dt_s": 0.5, "ny": 64, "nz": 64, "x_m": [0, 40]},
           "constrain": [mast]}  # fmt: skip
    status, _, out = server.call("POST", "/runs", big)  # over the server's memory budget with its conditioning
    assert status == 413 and "the constrained run (2 measurement streams) needs about" in out["detail"], out


def test_an_upload_a_queued_run_needs_is_not_deleted(tmp_path):
    """DELETE /constraints/<id> answers 409 while a queued or running run is conditioned on the upload, and removes
    it once that run has finished."""
    import threading
    from types import SimpleNamespace

    from turbgen.service.catalog import Catalog
    from turbgen.service.limits import LimitError
    from turbgen.service.routes.constraints import delete_upload

    catalog = Catalog(tmp_path)
    cid, _, _ = catalog.uploads.add("application/json", open(MAST, "rb").read())
    rid = "ab" * 12
    catalog.record(rid, "mann", {"seed": 1, "constrain": [cid]})
    state = SimpleNamespace(catalog=catalog, jobs=SimpleNamespace(lock=threading.Lock(), active={rid: None}))
    with pytest.raises(LimitError, match=f"run {rid} is queued or running on these measurements"):
        delete_upload(cid, state)
    assert catalog.uploads.path(cid).is_file()
    state.jobs.active.clear()
    assert delete_upload(cid, state) == {"id": cid, "deleted": True} and not list(catalog.uploads.dir.iterdir())
