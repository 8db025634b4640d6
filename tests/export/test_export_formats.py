"""Round trips of every export format: read back by our own readers (and weio for .bts/HAWC),
the files reproduce the store's velocities at every grid point within the format's
quantisation, with the direction conventions of file-formats.md checked on the raw bytes."""

from __future__ import annotations

import struct

import h5py
import numpy as np
import pytest

from export_fixtures import make_store
from turbgen.errors import ParameterError
from turbgen.exporters import (ExportRequest, export_store, read_bts, read_evo, read_hawc2, read_hdf5, read_mt4d,
                            read_sum, read_wnd)

HUB, U, ALPHA = 20.0, 10.0, 0.2
Z_REL = (np.arange(7) - 3) * 3.0
Y = (np.arange(5) - 2) * 2.0


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return make_store(tmp_path_factory.mktemp("store") / "s.zarr", hub_height_m=HUB, U_m_s=U)


def full(data, ix, c):
    """Expected full velocity (nt, ny, nz) of plane ix: fluctuation + power-law mean on u."""
    v = data[c][:, ix].astype(np.float64)
    if c == "u":
        v = v + U * ((HUB + Z_REL) / HUB) ** ALPHA
    return v


def bladed_tolerance(header, k):
    """Half an int16 step of the Bladed scaling (U 1e-5 TI%) plus float32 slack."""
    return 0.5 * header.U_m_s * 1e-5 * header.ti_percent[k] * (1 + 1e-5) + 1e-5


def test_bts_round_trip_own_reader(store, tmp_path):
    path, data = store
    export_store(path, "bts", tmp_path / "f.bts")
    b = read_bts(tmp_path / "f.bts")
    assert b["id"] == 8 and b["periodic"]
    assert b["dt_s"] == pytest.approx(0.1) and b["U_m_s"] == U and b["hub_height_m"] == HUB
    np.testing.assert_allclose(b["y"], Y)  # +y left, first column at -W/2
    np.testing.assert_allclose(b["z"], HUB + Z_REL)  # absolute heights, bottom row first
    for c in "uvw":
        exp = full(data, 0, c)
        step = (exp.max() - exp.min()) / 65535  # TurbSim scaling: the full range over 65535 counts
        assert np.abs(b[c] - exp).max() <= 0.5 * step * (1 + 1e-4)
        assert b[c].shape == (64, 5, 7)


def test_bts_raw_byte_order(store, tmp_path):
    """Record order: time slowest, then z, then y, component fastest (section 2.2)."""
    path, data = store
    export_store(path, "bts", tmp_path / "f.bts")
    raw = (tmp_path / "f.bts").read_bytes()
    head = struct.unpack_from("<h4i6f6fi", raw, 0)
    nz, ny, ntwr, nt = head[1:5]
    assert (nz, ny, ntwr, nt) == (7, 5, 0, 64)
    slopes, offs = head[11:17:2], head[12:17:2]
    ints = np.frombuffer(raw, "<i2", offset=70 + head[17])
    assert ints.size == nt * ny * nz * 3
    for (t, iy, iz, k) in [(0, 0, 0, 0), (0, 1, 0, 1), (0, 0, 1, 2), (5, 4, 6, 0), (63, 3, 2, 1)]:
        value = (ints[((t * nz + iz) * ny + iy) * 3 + k] - offs[k]) / slopes[k]
        assert value == pytest.approx(full(data, 0, "uvw"[k])[t, iy, iz], abs=1.0 / slopes[k])


def test_bts_round_trip_weio(store, tmp_path):
    weio_ts = pytest.importorskip("weio.turbsim_file")
    path, data = store
    export_store(path, "bts", tmp_path / "f.bts", ExportRequest(plane=2))
    ts = weio_ts.TurbSimFile(str(tmp_path / "f.bts"))
    assert ts["u"].shape == (3, 64, 5, 7)
    np.testing.assert_allclose(ts["y"], Y)
    np.testing.assert_allclose(ts["z"], HUB + Z_REL)
    for k, c in enumerate("uvw"):
        exp = full(data, 2, c)
        step = (exp.max() - exp.min()) / 65535
        assert np.abs(ts["u"][k] - exp).max() <= 0.5 * step * (1 + 1e-4) + 1e-6


def test_bts_tower_points(store, tmp_path):
    path, data = store
    export_store(path, "bts", tmp_path / "t.bts", ExportRequest(tower=True))
    b = read_bts(tmp_path / "t.bts")
    bottom = HUB + Z_REL[0]  # 11 m: points at 11, 8, 5, 2 m (above the ground)
    np.testing.assert_allclose(b["tower_z"], [11.0, 8.0, 5.0, 2.0])
    step = {c: (max(full(data, 0, c).max(), b[f"tower_{c}"].max()) - min(full(data, 0, c).min(), b[f"tower_{c}"].min()))
            / 65535 for c in "uvw"}
    fluct_u = data["u"][:, 0, 2, 0]  # y = 0 is column 2 of 5, lowest row
    exp_u = fluct_u[:, None] + U * (b["tower_z"][None, :] / HUB) ** ALPHA
    assert np.abs(b["tower_u"] - exp_u).max() <= 0.5 * step["u"] * (1 + 1e-4) + 1e-6
    assert np.abs(b["tower_w"] - data["w"][:, 0, 2, 0][:, None]).max() <= 0.5 * step["w"] * (1 + 1e-4) + 1e-6
    weio_ts = pytest.importorskip("weio.turbsim_file")
    ts = weio_ts.TurbSimFile(str(tmp_path / "t.bts"))
    np.testing.assert_allclose(ts["zTwr"], b["tower_z"])
    assert np.abs(ts["uTwr"][0] - exp_u).max() <= 0.5 * step["u"] * (1 + 1e-4) + 1e-5
    assert bottom == b["z"][0]


def test_bts_non_periodic_and_shear_option(store, tmp_path):
    path, data = store
    export_store(path, "bts", tmp_path / "n.bts", ExportRequest(periodic=False, shear_exponent=0.0, hub_height_m=90.0))
    b = read_bts(tmp_path / "n.bts")
    assert b["id"] == 7 and b["hub_height_m"] == 90.0
    np.testing.assert_allclose(b["z"], 90.0 + Z_REL)
    exp = data["u"][:, 0].astype(float) + U  # alpha = 0: uniform mean U
    assert np.abs(b["u"] - exp).max() <= 0.5 * (exp.max() - exp.min()) / 65535 * (1 + 1e-4)


def test_wnd_sum_round_trip(store, tmp_path):
    path, data = store
    export_store(path, "wnd", tmp_path / "r.wnd", ExportRequest(plane=1))
    w = read_wnd(tmp_path / "r.wnd")
    h = w["header"]
    assert (h.nt, h.ny, h.nz) == (64, 5, 7)
    assert h.dx_m == pytest.approx(U * 0.1) and h.U_m_s == U
    for k, c in enumerate("uvw"):
        assert np.abs(w[c] - full(data, 1, c)).max() <= bladed_tolerance(h, k)
        sigma = data[c][:, 1].std()
        assert h.ti_percent[k] >= 100 * sigma / U * (1 - 1e-6)  # TI at least sigma/U
    s = read_sum(tmp_path / "r.sum")
    assert s["hub_height_m"] == HUB and s["U_m_s"] == U and s["periodic"] and not s["clockwise"]
    assert s["height_offset_m"] == 0.0
    np.testing.assert_allclose(s["ti_percent"], h.ti_percent, rtol=1e-6)
    text = (tmp_path / "r.sum").read_text().upper()
    assert text.index("CLOCKWISE") < text.index("HUB HEIGHT") < text.index("UBAR") < text.index("HEIGHT OFFSET") \
        < text.index("PERIODIC")
    assert "LEFT-HAND" not in text


def test_wnd_raw_header_and_order(store, tmp_path):
    path, data = store
    export_store(path, "wnd", tmp_path / "r", ExportRequest())
    raw = (tmp_path / "r.wnd").read_bytes()
    h = struct.unpack_from("<hhi6f3fi4f4i6f", raw, 0)
    assert h[:3] == (-99, 4, 3) and h[12] == 32 and (h[19], h[20]) == (7, 5)  # nt/2, nz, ny
    ti, Uh = h[6:9], h[13]
    ints = np.frombuffer(raw, "<i2", offset=104)
    assert ints.size == 64 * 35 * 3
    for (t, iy, iz, k) in [(0, 1, 0, 0), (3, 0, 2, 1), (63, 4, 6, 2)]:
        value = Uh * ((1.0 if k == 0 else 0.0) + 1e-5 * ti[k] * ints[((t * 7 + iz) * 5 + iy) * 3 + k])
        assert value == pytest.approx(full(data, 0, "uvw"[k])[t, iy, iz], abs=Uh * 1e-5 * ti[k])


def test_evo_round_trip_reader_byte_order(store, tmp_path):
    path, data = store
    r = export_store(path, "evo", tmp_path / "lid")
    assert sorted(p.name for p in r.paths) == ["lid.evo", "lid.sum", "lid.wnd"]
    e = read_evo(tmp_path / "lid.evo")
    h = read_wnd(tmp_path / "lid.wnd")["header"]
    np.testing.assert_array_equal(e["x_up"], [0, 10, 25])
    for ix in range(3):
        for k, c in enumerate("uvw"):
            assert np.abs(e[c][ix] - full(data, ix, c)).max() <= bladed_tolerance(h, k)
    # independent byte-level check of the simulator READER's order: plane, time, z, y, component
    ints = np.fromfile(tmp_path / "lid.evo", "<i2")
    assert ints[0] == 3 and list(ints[1:4]) == [0, 10, 25]
    nt, nz, ny = 64, 7, 5
    for (p, t, iz, iy, k) in [(0, 0, 0, 1, 0), (1, 2, 3, 4, 1), (2, 63, 6, 0, 2), (2, 10, 0, 3, 0)]:
        raw = ints[4 + (((p * nt + t) * nz + iz) * ny + iy) * 3 + k]
        value = h.U_m_s * ((1.0 if k == 0 else 0.0) + 1e-5 * h.ti_percent[k] * raw)
        assert value == pytest.approx(full(data, p, "uvw"[k])[t, iy, iz], abs=bladed_tolerance(h, k))
    # ROOT.wnd carries the rotor plane; its TI scaling covers every plane
    w = read_wnd(tmp_path / "lid.wnd")
    assert np.abs(w["u"] - full(data, 0, "u")).max() <= bladed_tolerance(h, 0)
    assert read_sum(tmp_path / "lid.sum")["U_m_s"] == U


def test_evo_rounds_distances_and_refuses_what_the_format_cannot_hold(tmp_path):
    path, data = make_store(tmp_path / "frac.zarr", x_m=(0.0, 13.3, 26.6))  # the default Mann spacing
    r = export_store(path, "evo", tmp_path / "f")
    assert any("13.3->13" in n and "26.6->27" in n for n in r.notes)
    e = read_evo(tmp_path / "f.evo")
    np.testing.assert_array_equal(e["x_up"], [0, 13, 27])
    h = read_wnd(tmp_path / "f.wnd")["header"]
    assert np.abs(e["w"][2] - data["w"][:, 2]).max() <= bladed_tolerance(h, 2)
    path, _ = make_store(tmp_path / "close.zarr", x_m=(0.0, 0.4))
    with pytest.raises(ParameterError, match="coincide"):
        export_store(path, "evo", tmp_path / "e")
    path, _ = make_store(tmp_path / "odd.zarr", nt=63)
    with pytest.raises(ParameterError, match="odd"):
        export_store(path, "evo", tmp_path / "e")
    assert not list(tmp_path.glob("e*"))


def test_hawc2_round_trip_and_orientation(store, tmp_path):
    path, data = store
    r = export_store(path, "hawc2", tmp_path / "box")
    assert [p.name for p in r.paths] == ["box_u.bin", "box_v.bin", "box_w.bin"]
    h = read_hawc2(tmp_path / "box", (64, 5, 7), U)
    for c in "uvw":
        assert np.abs(h[c] - full(data, 0, c)).max() <= 4e-6  # float32 rounding of values up to ~15 m/s
    raw = np.fromfile(tmp_path / "box_v.bin", "<f4")
    assert raw.size == 64 * 5 * 7
    # z fastest (bottom up), then y from +W/2 (file y reversed), then x = time, first slice first
    np.testing.assert_array_equal(raw[:7], data["v"][0, 0, 4, :])
    np.testing.assert_array_equal(raw[7:14], data["v"][0, 0, 3, :])
    np.testing.assert_array_equal(raw[35:42], data["v"][1, 0, 4, :])
    text = "\n".join(r.inflowwind_lines)
    assert "WindProfile" in text and "RefHt_HAWC" in text and "URef" in text


def test_hawc2_round_trip_weio(store, tmp_path):
    weio_mb = pytest.importorskip("weio.mannbox_file")
    path, data = store
    export_store(path, "hawc2", tmp_path / "box", ExportRequest(plane=1))
    for c in "uvw":
        mb = weio_mb.MannBoxFile(str(tmp_path / f"box_{c}.bin"), N=(64, 5, 7), dy=2.0, dz=3.0)
        field = mb["field"].astype(np.float64) + (U if c == "u" else 0.0)  # weio flips y to increasing
        assert np.abs(field - full(data, 1, c)).max() <= 4e-6


def test_mt4d_round_trip_and_orientation(store, tmp_path):
    path, data = store
    export_store(path, "mt4d", tmp_path / "f.mt4d")
    m = read_mt4d(tmp_path / "f.mt4d", (64, 3, 5, 7))
    for c in "uvw":
        np.testing.assert_array_equal(m[c], data[c])
    raw = np.fromfile(tmp_path / "f.mt4d", "<f4")
    assert raw.size == 3 * 3 * 64 * 35
    # z fastest, y ascending, box x = reversed eddy time (largest x reaches the turbine first)
    np.testing.assert_array_equal(raw[:7], data["u"][63, 0, 0, :])
    np.testing.assert_array_equal(raw[7:14], data["u"][63, 0, 1, :])
    np.testing.assert_array_equal(raw[35:42], data["u"][62, 0, 0, :])
    np.testing.assert_array_equal(raw[64 * 35:64 * 35 + 7], data["u"][63, 1, 0, :])  # next slot = next plane
    np.testing.assert_array_equal(raw[3 * 64 * 35:3 * 64 * 35 + 7], data["v"][63, 0, 0, :])  # component slowest


def test_hdf5_round_trip_and_matlab_order(store, tmp_path):
    path, data = store
    export_store(path, "hdf5", tmp_path / "f.h5")
    f = read_hdf5(tmp_path / "f.h5")
    for c in "uvw":
        np.testing.assert_array_equal(f[c], data[c])
    np.testing.assert_allclose(f["x"], [0, 10, 25])
    np.testing.assert_allclose(f["y"], Y)
    np.testing.assert_allclose(f["z"], Z_REL)
    np.testing.assert_allclose(f["t"], np.arange(64) * 0.1)
    assert f["attrs"]["model"] == "kaimal" and f["attrs"]["U_m_s"] == U and "frame_note" in f["attrs"]
    with h5py.File(tmp_path / "f.h5") as h5:
        # row-major (z, y, x, t): MATLAB's h5read reverses it to (t, x, y, z)
        assert h5["u"].shape == (7, 5, 3, 64)
        assert h5["u"][2, 1, 0, 5] == data["u"][5, 0, 1, 2]


def test_below_ground_refused_or_dropped(tmp_path):
    path, data = make_store(tmp_path / "low.zarr", hub_height_m=9.0)  # lowest row at 9 - 9 = 0 m
    with pytest.raises(ParameterError, match="ground.*`drop_below_ground`"):
        export_store(path, "bts", tmp_path / "low.bts")
    assert not (tmp_path / "low.bts").exists()
    export_store(path, "bts", tmp_path / "low.bts", ExportRequest(drop_below_ground=True))
    b = read_bts(tmp_path / "low.bts")
    np.testing.assert_allclose(b["z"], 9.0 + Z_REL[1:])
    exp = data["w"][:, 0, :, 1:].astype(float)
    assert np.abs(b["w"] - exp).max() <= 0.5 * (exp.max() - exp.min()) / 65535 * (1 + 1e-4)
    export_store(path, "wnd", tmp_path / "low", ExportRequest(drop_below_ground=True))
    s = read_sum(tmp_path / "low.sum")
    # grid centre = hub - offset = 9 + (Z_REL[1] + Z_REL[-1]) / 2
    assert s["hub_height_m"] - s["height_offset_m"] == pytest.approx(9.0 + 0.5 * (Z_REL[1] + Z_REL[-1]))
    r = export_store(path, "hawc2", tmp_path / "lowbox", ExportRequest(drop_below_ground=True, overwrite=True))
    assert any("RefHt_HAWC" in line and "10.5" in line for line in r.inflowwind_lines)


@pytest.mark.parametrize("fmt", ["bts", "wnd", "evo", "hawc2", "mt4d", "hdf5"])
def test_memory_bounded_by_one_plane(tmp_path, fmt):
    """Streaming: the peak traced allocation does not grow with the number of planes. Holding the
    whole field would add (6 - 2) = 4 plane sizes; the measured run-to-run noise (zarr's async
    buffers) is below 0.5 plane, so we allow 1.5 planes."""
    import tracemalloc

    from turbgen.store import open_store

    plane_bytes = 512 * 8 * 8 * 4 * 3  # u, v, w of one plane, float32
    peaks = []
    for nx in (2, 6):
        path, _ = make_store(tmp_path / f"s{nx}.zarr", nt=512, ny=8, nz=8, x_m=tuple(10.0 * i for i in range(nx)))
        fs = open_store(path)
        tracemalloc.start()
        try:
            request = ExportRequest() if fmt in ("mt4d", "hdf5") else ExportRequest(hub_height_m=90.0)
            export_store(fs, fmt, tmp_path / f"out{nx}.{fmt}", request)
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
    assert peaks[1] - peaks[0] < 1.5 * plane_bytes
