"""The service's export takes `turbgen export`'s options (one mean-wind definition, the same checks): a profile,
veer, inline table and hub history give the bytes the library's export gives with the same MeanWind; bad values
are a 422 naming them, and nothing is cached for them."""

from __future__ import annotations

import io
import urllib.parse
import zipfile

import numpy as np
import pytest

from service_server import TINY_GRID, Server

from turbgen.exporters import ExportRequest, export_store, read_bts, read_hawc2
from turbgen.spec.mean_wind import MeanWind

TABLE = ((100.0, 8.5, 3.0), (150.0, 10.0, 0.0), (200.0, 11.0, -4.0))  # z [m], U [m/s], direction [deg]
HISTORY = ((2.0, 9.0, 0.0), (20.0, 11.0, 8.0))  # t [s], U [m/s], direction [deg]


def rows(table) -> str:
    return ";".join(",".join(f"{v:g}" for v in row) for row in table)


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    root = tmp_path_factory.mktemp("svc_export")
    srv = Server(root / "svc")
    try:
        rid = srv.call("POST", "/runs", {"model": "mann", "seed": 5, "U_m_s": 10.0, "grid": dict(TINY_GRID)})[2]["id"]
        srv.wait(rid)
        yield srv, rid, root / "svc" / "runs" / rid / "store.zarr"
    finally:
        srv.kill()


def get(srv, rid, **query):
    return srv.call("GET", f"/runs/{rid}/export?" + urllib.parse.urlencode({"format": "bts", **query}))


def test_log_profile_and_veer_as_the_library(served, tmp_path):
    srv, rid, store = served
    status, _, payload = get(srv, rid, profile="log:z0=0.03,d=1", veer=-0.2)
    assert status == 200, payload
    (tmp_path / "served.bts").write_bytes(payload)
    wind = MeanWind(profile="log", roughness_m=0.03, displacement_m=1.0, veer_deg_per_m=-0.2)
    export_store(store, "bts", tmp_path / "local.bts", ExportRequest(mean_wind=wind))
    got, want = read_bts(tmp_path / "served.bts"), read_bts(tmp_path / "local.bts")
    for c in "uvw":
        np.testing.assert_array_equal(got[c], want[c])
    default = get(srv, rid)[2]
    assert read_bts_bytes(default, tmp_path)["v"].std() < got["v"].std()  # the veer turned part of U into v


def read_bts_bytes(payload: bytes, folder) -> dict:
    (folder / "default.bts").write_bytes(payload)
    return read_bts(folder / "default.bts")


def test_inline_table_and_history_as_the_library(served, tmp_path):
    srv, rid, store = served
    status, _, payload = get(srv, rid, format="hawc2", profile="table:" + rows(TABLE), mean_history=rows(HISTORY),
                             runner_files="true")
    assert status == 200, payload
    zipfile.ZipFile(io.BytesIO(payload)).extractall(tmp_path / "h2")
    names = sorted(p.name for p in (tmp_path / "h2").iterdir())
    assert names == sorted([f"{rid}_{c}.bin" for c in "uvw"] + [f"{rid}_InflowWind_hawc2.dat", f"{rid}_wind.htc"])
    z, u, d = zip(*TABLE)
    t, hu, hd = zip(*HISTORY)
    wind = MeanWind(profile="table", table_heights_m=z, table_speeds_m_s=u, table_directions_deg=d,
                    history_times_s=t, history_speeds_m_s=hu, history_directions_deg=hd)
    export_store(store, "hawc2", tmp_path / "local", ExportRequest(mean_wind=wind))
    shape = (TINY_GRID["nt"], TINY_GRID["ny"], TINY_GRID["nz"])
    got, want = read_hawc2(tmp_path / "h2" / rid, shape, 10.0), read_hawc2(tmp_path / "local", shape, 10.0)
    for c in "uvw":
        np.testing.assert_array_equal(got[c], want[c])


@pytest.mark.parametrize("query, message", [
    ({"profile": "log:z0=-1"}, "log-law roughness z0 (m)"),
    ({"profile": "spline:3"}, "is not one of power:ALPHA"),
    ({"profile": "table:/etc/passwd"}, "is not numeric"),
    ({"veer": 9.0}, "veer (deg/m)"),
    ({"shear_exponent": 0.1, "profile": "power:0.2"}, "both set the profile"),
    ({"mean_history": "5,10;1,11"}, "must increase strictly"),
    ({"transient": "EOG"}, "needs --iec-class and --rotor-diameter"),
    ({"transient": "gust", "iec_class": "IIB", "rotor_diameter": 80}, "is not one of EOG"),
    ({"format": "mt4d", "veer": 0.1}, "does not use"),
    ({"format": "evo", "runner_files": "true"}, "absolute path, which the service does not reveal"),
])
def test_bad_values_are_422_and_nothing_is_cached(served, query, message):
    srv, rid, store = served
    before = sorted(p.name for p in (store.parent / "exports").iterdir()) if (store.parent / "exports").is_dir() else []
    status, _, body = get(srv, rid, **query)
    assert status == 422 and message in str(body), body
    after = sorted(p.name for p in (store.parent / "exports").iterdir()) if (store.parent / "exports").is_dir() else []
    assert after == before
