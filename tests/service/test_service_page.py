"""The service's pages in a real headless chromium: a run submitted through the form with non-default L, Gamma, evo
and grid, its page showing the field at the point chosen, an export downloaded and read back, the run deleted; and
the token still guarding what starts a computation. With TURBGEN_SCREENSHOTS=<dir> the test saves the screenshots
of docs/service.md there."""

from __future__ import annotations

import json
import os
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from service_server import Server
from test_service import MAST, SMALL_RUN, _until, _upload, browser  # noqa: F401  (the fixture: headless chromium)

from turbgen.exporters import export_store, read_bts
from turbgen.service.form import form_fields
from turbgen.store import open_store

TOKEN = "a-token-for-the-page-tests"
# the form's values (field name -> text) of the run: non-default L, Gamma, evo and grid
TYPED = {"L": "30", "gamma": "2.5", "evo": "150", "seed": "61", "nt": "128", "dt": "0.25", "ny": "6", "nz": "4",
         "dy": "3", "planes": "0,40", "U": "10"}  # fmt: skip
COMMAND = ("turbgen mann --L 30 --gamma 2.5 --evo 150 --seed 61 --nt 128 --dt 0.25 --ny 6 --nz 4 --dy 3 "
           "--planes 0,40 --U 10")  # fmt: skip


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    srv = Server(tmp_path_factory.mktemp("page") / "root", "--workers", "1")
    yield srv
    srv.kill()


def _screenshot(driver, name: str, element: str | None = None) -> None:
    """The page (or its ``element``, a CSS selector) as docs/<name>.png when TURBGEN_SCREENSHOTS names a folder."""
    from selenium.webdriver.common.by import By

    out = os.environ.get("TURBGEN_SCREENSHOTS")
    if out:
        height = driver.execute_script("return document.documentElement.scrollHeight")
        driver.set_window_size(1300, height + 150)
        target = driver.find_element(By.CSS_SELECTOR, element or "body")
        target.screenshot(str(Path(out) / f"{name}.png"))


def _type(driver, name: str, text: str) -> None:
    from selenium.webdriver.common.by import By

    field = driver.find_element(By.CSS_SELECTOR, f"#groups [name='{name}']")
    field.clear()
    field.send_keys(text)


def _js(driver, script: str, *args):
    return driver.execute_script(script, *args)


def _submit_through_the_form(driver, server) -> str:
    from selenium.webdriver.common.by import By

    driver.get(server.url + "/")
    _until(lambda: driver.find_elements(By.CSS_SELECTOR, "#groups .field"), 30, "the form was not built")
    names = {e.get_attribute("name") for e in driver.find_elements(By.CSS_SELECTOR, "#groups [name]")}
    assert names == {f.name for f in form_fields("mann")}  # every field named as the command's option
    _type(driver, "L", "0.5")  # the server's 422 shown inline, at the field it names
    err = "return document.querySelector('.field[data-name=L].bad .field-err')?.textContent"
    assert "L (length scale, m) = 0.5 is outside the allowed range [1, 1000]" in _until(
        lambda: _js(driver, err), 30, "no inline message at L")
    for name, text in TYPED.items():
        _type(driver, name, text)
    _until(lambda: driver.find_element(By.ID, "command").text == COMMAND, 30, "the command does not show the run")
    assert "turbgen.mann(L=30.0, gamma=2.5, evo=150.0, seed=61" in driver.find_element(By.ID, "python").text
    _screenshot(driver, "service-form", "#new-run")
    driver.find_element(By.ID, "submit-button").click()
    msg = _until(lambda: driver.find_element(By.ID, "message").text, 60, "no submit message")
    assert msg.startswith("submitted "), msg
    return msg.split()[1]


def _check_series(driver, server, rid: str, store) -> None:
    from selenium.webdriver.support.ui import Select
    from selenium.webdriver.common.by import By

    Select(driver.find_element(By.ID, "plane")).select_by_value("1")
    for name, value in (("y", "2"), ("z", "3")):
        driver.find_element(By.ID, name).clear()
        driver.find_element(By.ID, name).send_keys(value)
    driver.find_element(By.ID, "show-series").click()
    point = "return document.querySelector('#series').dataset.point"
    _until(lambda: _js(driver, point) == "1,2,3", 60, "no series at plane 1, y 2, z 3")
    curves = driver.find_elements(By.CSS_SELECTOR, "#series polyline.curve")
    assert [c.get_attribute("data-name") for c in curves] == ["u", "v", "w"]
    assert len(curves[0].get_attribute("points").split()) == 128
    status, _, series = server.call("GET", f"/runs/{rid}/series?plane=1&y=2&z=3")  # cached: the same JSON
    assert status == 200 and (series["x_m"], series["y_m"], series["z_m"]) == (40.0, -1.5, 4.5)
    for c in "uvw":
        np.testing.assert_allclose(series[c], store.array(c)[:, 1, 2, 3], atol=6e-6)


def _check_snapshot(driver, server, rid: str) -> None:
    loaded = "const i = document.querySelector('#snapshot'); return i.complete && i.naturalWidth > 0 && i.dataset.url"
    _until(lambda: "plane=1&t=0&component=u" in (_js(driver, loaded) or ""), 60, "no snapshot of plane 1")
    _js(driver, "const s = document.querySelector('#t'); s.value = 5; s.dispatchEvent(new Event('input'));")
    _until(lambda: "plane=1&t=5&component=u" in (_js(driver, loaded) or ""), 60, "the slider did not move the image")
    png = server.root / "runs" / rid / "view" / "snapshot-u-x1-t5.png"
    status, hdrs, payload = server.call("GET", f"/runs/{rid}/snapshot?plane=1&t=5&component=u")
    assert status == 200 and hdrs["content-type"] == "image/png" and payload == png.read_bytes()


def _download_bts(driver, store_path: Path, tmp_path: Path) -> None:
    from selenium.webdriver.common.by import By

    downloads = tmp_path / "downloads"
    downloads.mkdir()
    driver.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)})
    driver.find_element(By.CSS_SELECTOR, "button.make-export[data-format=bts]").click()
    link = _until(lambda: driver.find_elements(By.CSS_SELECTOR, "a.export[data-format=bts]"), 120, "no bts link")
    _screenshot(driver, "service-run")
    link[0].click()
    zips = _until(lambda: [p for p in downloads.glob("*.zip")], 60, "no download")
    with zipfile.ZipFile(zips[0]) as z:  # the .bts with the runner files (InflowWind input file, HAWC2 block)
        names = z.namelist()
        z.extractall(tmp_path / "got")
    assert any(n.endswith(".dat") for n in names), names
    (bts,) = [n for n in names if n.endswith(".bts")]
    export_store(store_path, "bts", tmp_path / "local.bts")
    got, want = read_bts(tmp_path / "got" / bts), read_bts(tmp_path / "local.bts")
    for c in "uvw":
        np.testing.assert_array_equal(got[c], want[c])


def test_a_run_through_the_page_from_the_form_to_its_deletion(server, browser, tmp_path):  # noqa: F811
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select

    kaimal = {"model": "kaimal", "preset": "stable", "U_m_s": 8.0, "seed": 2, "grid": {"nt": 128, "ny": 6, "nz": 6,
                                                                                    "x_m": [0.0, 30.0]}}  # fmt: skip
    other = server.call("POST", "/runs", kaimal)[2]["id"]  # submitted first: listed below
    rid = _submit_through_the_form(browser, server)
    row = f"#run-{rid} .status"
    text = "const e = document.querySelector(arguments[0]); return e ? e.textContent : null;"
    _until(lambda: _js(browser, text, row) == "complete", 120, "run not complete")
    _until(lambda: _js(browser, text, f"#run-{other} .status") == "complete", 60, "Kaimal run not complete")
    ids = "return Array.from(document.querySelectorAll('#catalog tbody tr')).map(r => r.id)"
    assert _js(browser, ids) == [f"run-{rid}", f"run-{other}"]  # newest first
    _screenshot(browser, "service-catalog", "#catalog-section")
    Select(browser.find_element(By.ID, "f-model")).select_by_visible_text("kaimal")
    _until(lambda: _js(browser, ids) == [f"run-{other}"], 30, "the model filter did not apply")
    Select(browser.find_element(By.ID, "f-model")).select_by_visible_text("any")
    _until(lambda: len(_js(browser, ids)) == 2, 30, "the filter was not lifted")
    store_path = server.root / "runs" / rid / "store.zarr"
    attrs = xr.open_zarr(f"{server.url}/runs/{rid}/store").attrs  # the store's own record of the run
    p, g = attrs["parameters"], attrs["grid"]
    assert (p["length_scale_m"], p["gamma"], p["evo_time_s"], p["seed"]) == (30.0, 2.5, 150.0, 61)
    assert (g["nt"], g["dt_s"], g["ny"], g["nz"], g["dy_m"], g["dz_m"], g["x_m"]) == (128, 0.25, 6, 4, 3.0, 3.0,
                                                                                     [0.0, 40.0])  # fmt: skip
    assert _js(browser, text, f"#run-{rid} .store-url") == f"{server.url}/runs/{rid}/store"
    _js(browser, "document.querySelector(arguments[0]).click();", f"#run-{rid} a.view")
    _until(lambda: browser.current_url == f"{server.url}/runs/{rid}/view", 30, "the row does not open the run page")
    _check_series(browser, server, rid, open_store(store_path))
    _check_snapshot(browser, server, rid)
    _download_bts(browser, store_path, tmp_path)
    browser.get(server.url + "/")
    for _ in range(2):  # the first click asks, the second deletes
        _until(lambda: _js(browser, text, f"#run-{rid} button.delete"), 30, "no delete button")
        _js(browser, "document.querySelector(arguments[0]).click();", f"#run-{rid} button.delete")
        _until(lambda: _js(browser, text, f"#run-{rid} button.delete") != "delete", 30, "no confirmation asked")
    _until(lambda: not browser.find_elements(By.ID, f"run-{rid}"), 30, "the row stayed")
    assert server.call("GET", f"/runs/{rid}")[0] == 404 and not store_path.exists()


def test_the_token_still_guards_what_starts_a_computation(tmp_path):
    token_file = tmp_path / "token"
    token_file.write_text(TOKEN + "\n")
    token_file.chmod(0o600)
    srv = Server(tmp_path / "root", "--token-file", str(token_file))
    try:
        auth = {"Authorization": f"Bearer {TOKEN}"}
        assert srv.call("GET", "/form.json")[2]["token_required"] is True
        status, _, out = srv.call("GET", "/form/request?model=mann&seed=5&nt=256&ny=8&nz=8&planes=0,50&U=10")
        assert status == 200, out  # reading the form's request starts nothing
        assert srv.call("POST", "/runs", out["body"])[0] == 401
        status, _, sub = srv.call("POST", "/runs", out["body"], headers=auth)
        assert status == 202, sub
        rid = sub["id"]
        srv.wait(rid)
        for path in (f"/runs/{rid}/series?plane=1&y=2&z=3", f"/runs/{rid}/snapshot?t=3&component=w"):
            assert srv.call("GET", path)[0] == 401, path  # not made yet: making it needs the token
            assert srv.call("GET", path, headers=auth)[0] == 200, path
            assert srv.call("GET", path)[0] == 200, path  # made: readable by anyone who may read the store
        assert srv.call("GET", f"/runs/{rid}/view")[0] == 200
        lidar = {"kind": "pulsed", "mount": "nacelle", "ranges_m": [50.0], "beam_rate_hz": 1.0, "rotor_radius_m": 10.0,
                 "azimuth_deg": [0.0], "elevation_deg": [0.0], "fwhm_m": 30.0}  # fmt: skip
        assert srv.call("POST", f"/runs/{rid}/lidar", lidar)[0] == 401
        assert srv.call("DELETE", f"/runs/{rid}")[0] == 401
        assert srv.call("DELETE", f"/runs/{rid}", headers=auth)[0] == 200
    finally:
        srv.kill()


def test_the_pages_load_nothing_from_another_host_and_refuse_other_names(server):
    import re

    from turbgen.service.pages import static_files

    external = re.compile(r"""(?:src|href|action)\s*=\s*["']?\s*(?:[a-z][a-z0-9+.-]*:)?//"""  # another host
                          r"""|@import|url\(\s*["']?(?:https?:)?//|fetch\(\s*["'`](?:https?:)?//""", re.IGNORECASE)  # fmt: skip
    assert static_files() == {"index.js", "run.js", "common.js", "page.css"}
    for path in ["/", *(f"/static/{name}" for name in static_files())]:
        status, hdrs, page = server.call("GET", path)
        assert status == 200 and not external.search(page.decode()) and "cdn" not in page.decode().lower(), path
    for path in ("/static/..%2Fform.py", "/static/form.py", "/static/index.html", "/runs/000000000000000000000000/view"):
        assert server.call("GET", path)[0] == 404, path


def test_the_run_page_says_what_conditioning_did(server, browser):  # noqa: F811
    """A run conditioned on an uploaded mast: its page lists the command's lines about the data (the status's
    ``summary.conditioning``, tested against the command in test_service), one per line."""
    from selenium.webdriver.common.by import By

    up = _upload(server, Path(MAST).read_bytes(), "application/json")[2]["id"]
    rid = server.call("POST", "/runs", {"model": "mann", **SMALL_RUN, "constrain": [up], "noise_m_s": 0.1})[2]["id"]
    lines = server.wait(rid, timeout_s=120)["summary"]["conditioning"]
    assert lines[0].startswith("constrained (conditional sample) on ") and f"/constraints/{up}" in lines[0], lines
    browser.get(f"{server.url}/runs/{rid}/view")
    rows = lambda: [r for r in browser.find_elements(By.CSS_SELECTOR, "#parameters tr")  # noqa: E731
                    if r.find_element(By.TAG_NAME, "th").text == "conditioning"]
    row = _until(rows, 60, "no conditioning row")[0]
    assert row.find_element(By.TAG_NAME, "td").text.splitlines() == lines


@pytest.mark.slow
def test_the_run_page_shows_the_lidar_against_theory_and_the_validation(server, browser, tmp_path):  # noqa: F811
    """A field wide enough for the nacelle lidar's beams (16 x 16 points 8 m apart, the 11 default planes)."""
    from selenium.webdriver.common.by import By

    run = {"model": "mann", "U_m_s": 12.0, "seed": 4, "grid": {"nt": 1024, "ny": 16, "nz": 16, "dy_m": 8.0}}
    rid = server.call("POST", "/runs", run)[2]["id"]
    server.wait(rid, timeout_s=180)
    browser.get(f"{server.url}/runs/{rid}/view")
    _until(lambda: browser.find_elements(By.CSS_SELECTOR, "#series polyline.curve"), 60, "no time series")
    browser.find_element(By.ID, "run-lidar").click()
    verdict = "#lidar-report p.passed, #lidar-report p.failed"
    _until(lambda: browser.find_elements(By.CSS_SELECTOR, verdict), 120, "no lidar report")
    report = server.call("GET", f"/runs/{rid}/lidar?lidar=nacelle-4beam")[2]["report"]  # cached: the same
    shown = browser.find_element(By.CSS_SELECTOR, verdict).text
    assert shown.startswith("coherence γ²RL: " + ("passed" if report["verdict"]["passed"] else "failed")), shown
    names = [c.get_attribute("data-name") for c in browser.find_elements(By.CSS_SELECTOR, "#lidar-report .curve")]
    assert names == ["simulated", "theory"]
    # a lidar file of the user's (examples/mylidar.toml as JSON): its content is sent, no path
    lidar = tomllib.loads((Path(__file__).parents[2] / "examples" / "mylidar.toml").read_text())
    (tmp_path / "mylidar.json").write_text(json.dumps(lidar))
    browser.find_element(By.ID, "lidar-file").send_keys(str(tmp_path / "mylidar.json"))
    name = "return document.querySelector('#lidar-report .lidar-name')?.textContent"
    _until(lambda: _js(browser, name) == "my-2beam-pulsed", 120, "no report of the lidar file")
    status, _, mine = server.call("POST", f"/runs/{rid}/lidar", lidar)
    assert status == 200 and mine["report"]["lidar"]["ranges_m"] == [50.0, 103.2, 156.4]
    assert len(list((server.root / "runs" / rid / "lidar").iterdir())) == 2  # the preset's and the file's, cached
    browser.find_element(By.ID, "validate").click()
    imgs = _until(lambda: browser.find_elements(By.CSS_SELECTOR, "#validation img.plot"), 180, "no validation plots")
    _until(lambda: all(_js(browser, "return arguments[0].complete && arguments[0].naturalWidth", i) for i in imgs),
           60, "the validation plots did not load")  # fmt: skip
    passed = server.call("GET", f"/runs/{rid}")[2]["validation"]["passed"]
    assert browser.find_element(By.ID, "validation-status").text == ("passed" if passed else "failed")
    _screenshot(browser, "service-products", "#complete")
