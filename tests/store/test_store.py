"""The zarr field store: layout, round trip, atomic/safe writing, refusals, memory check."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import textwrap
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
import zarr

from turbgen import oscalls, resources
from turbgen.errors import ParameterError, StoreError, TurbgenError
from turbgen.grid import Grid
from turbgen.store import FieldStore, create_store, layout, open_store, physical_time_view
from turbgen.store.temporaries import remove_dead_temporaries

GRID = Grid(nt=10, dt_s=0.5, x_m=(0.0, 50.0, 63.3), ny=4, nz=3, dy_m=10.0, dz_m=8.0)
ATTRS = {
    "model": "mann",
    "parameters": {"L_m": 49.0, "gamma": np.float32(3.1), "evo_s": 400.0, "planes_m": (0.0, 50.0, 63.3)},
    "units": {"L_m": "m", "gamma": "1", "evo_s": "s", "planes_m": "m"},
    "seed": np.int64(7),
    "U_m_s": 16.0,
    "hub_height_m": 150.0,
}


def field(grid=GRID, seed=0):
    rng = np.random.default_rng(seed)
    return {c: rng.standard_normal(grid.shape).astype(np.float32) for c in layout.COMPONENTS}


def write_store(path, data, grid=GRID, attrs=ATTRS, **kw):
    with create_store(path, grid, attrs, **kw) as w:
        for c in layout.COMPONENTS:
            for ix in range(grid.nx):
                w.write(c, ix, data[c][:, ix])
    return path


def siblings(path: Path) -> list[str]:
    return sorted(p.name for p in path.parent.iterdir())


# -- round trip and layout ----------------------------------------------------------------------
def test_round_trip_values_coords_attrs(tmp_path):
    data = field()
    path = write_store(tmp_path / "f.zarr", data, chunk_t=4)
    fs = open_store(path)
    assert isinstance(fs, FieldStore)
    assert fs.grid == GRID and fs.model == "mann" and fs.U_m_s == 16.0 and fs.hub_height_m == 150.0
    assert fs.seed == 7 and fs.chunk_t == 4
    for c in layout.COMPONENTS:
        arr = fs.array(c)
        assert arr.dtype == np.float32 and arr.shape == GRID.shape
        assert arr.chunks == (4, 1, GRID.ny, GRID.nz)
        assert tuple(arr.metadata.dimension_names) == ("t", "x", "y", "z")
        np.testing.assert_array_equal(arr[:], data[c])
        np.testing.assert_array_equal(fs.read_plane(c, 2), data[c][:, 2])
        np.testing.assert_array_equal(fs.dask(c).compute(), data[c])
    g = zarr.open_group(str(path), mode="r")
    for name, values in layout.coordinates(GRID).items():
        np.testing.assert_array_equal(g[name][:], values)
        assert g[name].attrs["units"] == layout.COORD_ATTRS[name]["units"]
    a = fs.attrs
    assert a["parameters"]["gamma"] == 3.1  # numpy float32 stored as its short decimal
    assert a["parameters"]["planes_m"] == [0.0, 50.0, 63.3]
    assert a["frame"] == "convected" and "t = T + x/U" in a["frame_note"]
    assert a["grid"]["x_m"] == [0.0, 50.0, 63.3] and a["turbgen_complete"] is True
    assert a["created_utc"].endswith("+00:00") and a["turbgen_version"]
    assert list(a)[-1] == "turbgen_complete"  # the marker is the last attribute written


def test_attributes_added_after_generation_precede_the_marker(tmp_path):
    data = field()
    with create_store(tmp_path / "r.zarr", GRID, ATTRS) as w:
        for c in layout.COMPONENTS:
            for ix in range(GRID.nx):
                w.write(c, ix, data[c][:, ix])
        w.add_attrs(synthesis_report={"clip_error": np.float64(0.0)})
        with pytest.raises(ValueError, match="already set"):
            w.add_attrs(seed=3)
    a = open_store(tmp_path / "r.zarr").attrs
    assert a["synthesis_report"] == {"clip_error": 0.0} and a["seed"] == 7
    assert list(a)[-1] == "turbgen_complete"


def test_xarray_open_gives_named_dims_and_coords(tmp_path):
    xr = pytest.importorskip("xarray")
    data = field()
    path = write_store(tmp_path / "f.zarr", data)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # consolidated metadata present: no fallback warning
        ds = xr.open_zarr(path)
    assert ds.u.dims == ("t", "x", "y", "z")
    assert dict(ds.sizes) == {"t": 10, "x": 3, "y": 4, "z": 3}
    np.testing.assert_allclose(ds.x.values, [0.0, 50.0, 63.3])  # x = 0 not masked as a fill value
    np.testing.assert_allclose(ds.z.values, [-8.0, 0.0, 8.0])
    assert ds.t.attrs["units"] == "s" and ds.y.attrs["units"] == "m" and ds.u.attrs["units"] == "m s-1"
    assert "long_name" in ds.x.attrs
    np.testing.assert_array_equal(ds.w.values, data["w"])
    assert ds.attrs["model"] == "mann"


def test_physical_time_view(tmp_path):
    pytest.importorskip("xarray")
    path = write_store(tmp_path / "f.zarr", field())
    ds = physical_time_view(path)
    assert ds.T.dims == ("t", "x") and ds.T.attrs["units"] == "s"
    # T = t - x/U: plane at 50 m upstream, U = 16 m/s -> 3.125 s earlier than its eddy time
    np.testing.assert_allclose(ds.T.values[:, 1], GRID.t() - 50.0 / 16.0)
    np.testing.assert_allclose(ds.T.values[:, 0], GRID.t())
    assert physical_time_view(open_store(path)).T.shape == (10, 3)


def test_blockwise_and_threaded_writes_equal_one_shot(tmp_path):
    data = field(seed=3)
    path = tmp_path / "threads.zarr"
    spans = ((0, 3), (3, 7), (7, 10))
    blocks = [(c, ix, t0, t1) for c in layout.COMPONENTS for ix in range(GRID.nx) for t0, t1 in spans]
    with create_store(path, GRID, ATTRS, chunk_t=4) as w:  # blocks straddle chunk boundaries
        with ThreadPoolExecutor(4) as pool:
            list(pool.map(lambda b: w.write(b[0], b[1], data[b[0]][b[2] : b[3], b[1]], t0=b[2]), blocks[::-1]))
    fs = open_store(path)
    for c in layout.COMPONENTS:
        np.testing.assert_array_equal(fs.array(c)[:], data[c])


def test_write_rejects_bad_blocks(tmp_path):
    with pytest.raises(ValueError, match="does not fit"):
        with create_store(tmp_path / "a.zarr", GRID, ATTRS) as w:
            w.write("u", 0, np.zeros((11, 4, 3)))
    with pytest.raises(ValueError, match="NaN"):
        with create_store(tmp_path / "b.zarr", GRID, ATTRS) as w:
            w.write("u", 0, np.full((10, 4, 3), np.nan))
    with pytest.raises(ValueError, match="component"):
        with create_store(tmp_path / "c.zarr", GRID, ATTRS) as w:
            w.write("q", 0, np.zeros((10, 4, 3)))
    assert list(tmp_path.iterdir()) == []  # nothing installed, temp dirs removed


def test_unwritten_plane_is_not_installed(tmp_path):
    data = field()
    path = tmp_path / "f.zarr"
    with pytest.raises(RuntimeError, match="v at plane x = 50 m was not written"):
        with create_store(path, GRID, ATTRS) as w:
            for c in layout.COMPONENTS:
                for ix in range(GRID.nx):
                    if (c, ix) != ("v", 1):
                        w.write(c, ix, data[c][:, ix])
    assert siblings(path) == []


def test_chunks_written_counts_a_store_being_written_as_zarr_does(tmp_path):
    from turbgen.service.catalog import Catalog
    from turbgen.store.reader import chunks_written

    data, catalog, rid = field(), Catalog(tmp_path), "0" * 24  # a run of the service, being made
    catalog.record(rid, "mann", {})
    path = catalog.store_path(rid)
    with create_store(path, GRID, ATTRS, chunk_t=4) as w:  # 3 time chunks per plane
        w.write("u", 0, data["u"][:, 0])
        w.write("v", 2, data["v"][:8, 2], t0=0)  # 2 of the plane's chunks
        (tmp,) = (p for p in path.parent.iterdir() if p.name.startswith(f".{path.name}"))
        zarr_count = sum(zarr.open_array(str(tmp / c), mode="r").nchunks_initialized for c in layout.COMPONENTS)
        assert chunks_written(tmp) == zarr_count == 5 and catalog.progress(rid, 4) == 4
        for c in layout.COMPONENTS:
            for ix in range(GRID.nx):
                w.write(c, ix, data[c][:, ix])
    assert chunks_written(path) == 3 * GRID.nx * 3 and catalog.progress(rid, 99) == 0  # published: no temporary


@pytest.mark.parametrize(
    "change, match",
    [
        ({"model": None}, "lack"),
        ({"grid": {}}, "set by the writer"),
        ({"units": {"L_m": "m"}}, "lack a unit"),
        ({"model": "von-karman"}, "model"),
        ({"U_m_s": -1.0}, "U_m_s"),
    ],
)
def test_create_store_checks_attrs(tmp_path, change, match):
    attrs = {**ATTRS, **change}
    attrs = {k: v for k, v in attrs.items() if v is not None}
    with pytest.raises(ValueError, match=match):
        create_store(tmp_path / "f.zarr", GRID, attrs)
    assert siblings(tmp_path / "f.zarr") == []


# -- overwrite and interruption -----------------------------------------------------------------
def test_existing_store_refused_before_anything_is_written(tmp_path):
    path = write_store(tmp_path / "f.zarr", field(seed=1))
    before = sorted(str(p) for p in path.rglob("*"))
    with pytest.raises(StoreError, match="already exists; use `overwrite`"):
        create_store(path, GRID, ATTRS)
    assert siblings(path) == ["f.zarr"]
    assert sorted(str(p) for p in path.rglob("*")) == before
    np.testing.assert_array_equal(open_store(path).array("u")[:], field(seed=1)["u"])


def test_overwrite_replaces_only_when_complete(tmp_path):
    path = write_store(tmp_path / "f.zarr", field(seed=1))
    # an interrupted overwrite leaves the old store intact
    with pytest.raises(KeyboardInterrupt):
        with create_store(path, GRID, ATTRS, overwrite=True) as w:
            w.write("u", 0, field(seed=2)["u"][:, 0])
            raise KeyboardInterrupt
    assert siblings(path) == ["f.zarr"]
    np.testing.assert_array_equal(open_store(path).array("u")[:], field(seed=1)["u"])
    # a completed overwrite replaces it and leaves nothing else behind
    write_store(path, field(seed=2), overwrite=True)
    assert siblings(path) == ["f.zarr"]
    np.testing.assert_array_equal(open_store(path).array("u")[:], field(seed=2)["u"])


def test_overwrite_never_replaces_a_non_store(tmp_path):
    precious = tmp_path / "results"
    precious.mkdir()
    (precious / "thesis.tex").write_text("x")
    with pytest.raises(StoreError, match="not a turbgen store; it will not be replaced"):
        create_store(precious, GRID, ATTRS, overwrite=True)
    assert (precious / "thesis.tex").read_text() == "x"


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_exception_in_with_block_leaves_nothing(tmp_path, exc):
    path = tmp_path / "f.zarr"
    with pytest.raises(exc):
        with create_store(path, GRID, ATTRS) as w:
            w.write("u", 0, field()["u"][:, 0])
            assert any(n.startswith(".f.zarr.tmp-") for n in siblings(path))  # writing goes to a temp name
            raise exc("stop")
    assert siblings(path) == []


def _writer_script(path, kill_line):
    return textwrap.dedent(
        f"""
        import os, signal, numpy as np
        from turbgen.grid import Grid
        from turbgen.store import create_store
        g = Grid(nt=10, dt_s=0.5, x_m=(0.0, 50.0, 63.3), ny=4, nz=3, dy_m=10.0, dz_m=8.0)
        attrs = dict(model="kaimal", parameters={{}}, units={{}}, seed=1, U_m_s=10.0, hub_height_m=90.0)
        with create_store({str(path)!r}, g, attrs) as w:
            for ix in range(3):
                w.write("u", ix, np.ones((10, 4, 3)))
            {kill_line}
        """
    )


def test_sigterm_cleans_up(tmp_path):
    # the application's handler (turbgen.interruption, installed by the CLI) turns SIGTERM into SystemExit: the
    # writer's with block removes its temporary
    path = tmp_path / "f.zarr"
    script = _writer_script(path, "os.kill(os.getpid(), signal.SIGTERM); signal.pause()")
    script = "from turbgen.interruption import exit_on_signals\nwith exit_on_signals():\n" + textwrap.indent(script, "    ")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, timeout=120)
    assert proc.returncode == 128 + 15, proc.stderr.decode()
    assert list(tmp_path.iterdir()) == []


def test_sigterm_without_a_handler_leaves_only_a_dead_writers_temporary(tmp_path):
    # the library installs no handler: SIGTERM kills a bare writer outright, like SIGKILL; what it leaves is a
    # temporary of a dead writer (removed by the next writer), never a store
    path = tmp_path / "f.zarr"
    script = _writer_script(path, "os.kill(os.getpid(), signal.SIGTERM); signal.pause()")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, timeout=120)
    assert proc.returncode == -15, proc.stderr.decode()
    assert not path.exists()
    (tmp,) = list(tmp_path.iterdir())
    assert remove_dead_temporaries(tmp_path, ["f.zarr"]) == [tmp]


def test_killed_writer_leaves_no_complete_looking_store(tmp_path):
    """A SIGKILL mid-write (no cleanup possible) leaves only a temp dir that open_store refuses."""
    path = tmp_path / "f.zarr"
    script = _writer_script(path, "os.kill(os.getpid(), signal.SIGKILL)")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, timeout=120)
    assert proc.returncode == -9, proc.stderr.decode()
    assert not path.exists()
    (tmp,) = [p for p in tmp_path.iterdir()]
    assert tmp.name.startswith(".f.zarr.tmp-")
    with pytest.raises(StoreError, match="no such store.*interrupted write left"):
        open_store(path)
    with pytest.raises(StoreError, match="incomplete"):
        open_store(tmp)
    # a partial copy of the temp dir to the target name is refused as well
    shutil.copytree(tmp, path)
    with pytest.raises(StoreError, match="incomplete"):
        open_store(path)


# -- open_store refusals -----------------------------------------------------------------------
def _one_line_refusal(path, match):
    with pytest.raises(StoreError, match=match) as info:
        open_store(path)
    assert "\n" not in str(info.value)
    assert isinstance(info.value, TurbgenError) and not isinstance(info.value, ParameterError)
    from turbgen.cli import user_error

    assert user_error(info.value).exit_code == 2  # the CLI turns it into exit code 2


def test_open_store_refuses_missing_file_and_foreign_paths(tmp_path):
    _one_line_refusal(tmp_path / "nothing.zarr", "no such store")
    (tmp_path / "file.zarr").write_text("hello")
    _one_line_refusal(tmp_path / "file.zarr", "is a file")
    (tmp_path / "dir").mkdir()
    _one_line_refusal(tmp_path / "dir", r"not a turbgen store \(no zarr.json\)")
    zarr.open_group(str(tmp_path / "plain.zarr"), mode="w", attributes={"x": 1})
    _one_line_refusal(tmp_path / "plain.zarr", "not a turbgen store")


def _edit_root_attrs(path, edit):
    meta_file = path / "zarr.json"
    meta = json.loads(meta_file.read_text())
    edit(meta["attributes"])
    meta_file.write_text(json.dumps(meta))


def test_open_store_refuses_incomplete_and_corrupted(tmp_path):
    src = write_store(tmp_path / "good.zarr", field())

    def copy(name):
        return Path(shutil.copytree(src, tmp_path / name))

    no_marker = copy("no_marker.zarr")
    _edit_root_attrs(no_marker, lambda a: a.pop("turbgen_complete"))
    _one_line_refusal(no_marker, "incomplete .no completeness marker")

    bad_attr = copy("bad_attr.zarr")
    _edit_root_attrs(bad_attr, lambda a: a["grid"].update(nt="ten"))
    _one_line_refusal(bad_attr, "corrupted: attribute grid/nt")

    garbage = copy("garbage.zarr")
    (garbage / "zarr.json").write_text("{not json")
    _one_line_refusal(garbage, "corrupted: zarr.json unreadable")

    missing_chunk = copy("missing_chunk.zarr")
    chunk = sorted(p for p in (missing_chunk / "w" / "c").rglob("*") if p.is_file())[0]
    chunk.unlink()
    _one_line_refusal(missing_chunk, "incomplete: w has 2 of 3 chunk files")

    no_meta = copy("no_meta.zarr")
    (no_meta / "v" / "zarr.json").unlink()
    _one_line_refusal(no_meta, "v/zarr.json is missing")

    wrong_shape = copy("wrong_shape.zarr")
    g = zarr.open_group(str(wrong_shape), mode="a")
    del g["u"]
    g.create_array("u", shape=(10, 3, 5, 3), dtype="float32", dimension_names=("t", "x", "y", "z"))[:] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        zarr.consolidate_metadata(str(wrong_shape))
    _one_line_refusal(wrong_shape, r"corrupted: u has shape \(10, 3, 5, 3\)")

    wrong_coord = copy("wrong_coord.zarr")
    zarr.open_array(str(wrong_coord / "x"), mode="r+")[:] = [0.0, 60.0, 63.3]
    _one_line_refusal(wrong_coord, "coordinate 'x' does not match")

    open_store(src)  # the source is still fine


# -- memory -------------------------------------------------------------------------------------
def test_require_memory_message_names_need_available_and_option(monkeypatch):
    monkeypatch.setattr(resources, "available_memory_bytes", lambda: 2 * 2**30)
    with pytest.raises(ParameterError) as info:
        resources.require_memory(3 * 2**30, "the Mann snapshot", "lower --nt or --pad-yz")
    msg = str(info.value)
    assert msg == (
        "the Mann snapshot needs about 3.0 GiB of memory but only 2.0 GiB is available; lower --nt or --pad-yz"
    )
    assert resources.require_memory(2**30, "x", "y") == 2 * 2**30
    monkeypatch.setattr(resources, "available_memory_bytes", lambda: None)
    assert resources.require_memory(2**60, "x", "y") is None  # unknown -> no refusal


def test_resident_bytes_reads_vmrss(tmp_path):
    status = tmp_path / "status"
    status.write_text("Name:\tpython\nVmHWM:\t  300000 kB\nVmRSS:\t  123456 kB\n")
    assert oscalls.resident_bytes(status) == 123456 * 1024
    assert oscalls.resident_bytes(tmp_path / "absent") is None
    assert oscalls.resident_bytes() > 10 * 2**20  # this interpreter (Linux)


def test_available_memory_reads_meminfo_and_cgroup(tmp_path):
    meminfo = tmp_path / "meminfo"
    meminfo.write_text("MemTotal:  8000000 kB\nMemFree:  100 kB\nMemAvailable:  4000000 kB\n")
    cg = tmp_path / "cg"
    cg.mkdir()
    assert resources.available_memory_bytes(meminfo, cg) == 4000000 * 1024
    (cg / "memory.max").write_text("max\n")
    (cg / "memory.current").write_text("1000\n")
    assert resources.available_memory_bytes(meminfo, cg) == 4000000 * 1024  # no cgroup limit
    (cg / "memory.max").write_text(f"{2 * 2**30}\n")
    (cg / "memory.current").write_text(f"{2**30}\n")
    assert resources.available_memory_bytes(meminfo, cg) == 2**30  # the container limit is tighter
    assert resources.available_memory_bytes(tmp_path / "absent", tmp_path / "absent") > 0  # sysconf fallback
    assert resources.format_bytes(512) == "512 B" and resources.format_bytes(1536) == "1.5 KiB"



def test_writer_leaves_signal_handlers_and_hooks_alone(tmp_path):
    # a library behaves: writing a store changes no process-wide state (handlers, unraisable hook)
    before = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT)}
    hook = sys.unraisablehook
    with pytest.raises(RuntimeError):
        with create_store(tmp_path / "f.zarr", GRID, ATTRS):
            assert {s: signal.getsignal(s) for s in before} == before and sys.unraisablehook is hook
            raise RuntimeError
    assert {s: signal.getsignal(s) for s in before} == before and sys.unraisablehook is hook


def test_schema_file_is_valid_and_reachable_via_symlink():
    import jsonschema

    repo_schema = Path(__file__).resolve().parents[2] / "schemas" / "field.schema.json"
    schema = json.loads(repo_schema.read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    assert set(layout.CALLER_ATTRS + layout.WRITER_ATTRS + (layout.MARKER,)) == set(schema["required"])


def test_a_stop_request_publishes_nothing(tmp_path, monkeypatch):
    # an application's stop request (turbgen.cancellation; the CLI makes one on a signal) reaches a writer whose
    # block ended normally: it raises the requested exception and removes its temporary
    from turbgen import cancellation

    monkeypatch.setattr(cancellation, "_requests", [])
    path = tmp_path / "f.zarr"
    with pytest.raises(SystemExit) as info:
        with create_store(path, GRID, ATTRS) as w:
            for c in ("u", "v", "w"):
                for ix in range(GRID.nx):
                    w.write(c, ix, field()[c][:, ix])
            cancellation.request_stop(SystemExit(143))
    assert info.value.code == 143
    assert siblings(path) == [] and not path.exists()


# -- plausibility (issue 27: garbage that decodes) ----------------------------------------------------------
def test_writer_records_the_rms_of_each_component_and_readers_refuse_values_beyond_100_times_it(tmp_path):
    data = field()
    data["w"] *= 0.5
    path = write_store(tmp_path / "f.zarr", data, chunk_t=4)
    rms = open_store(path).attrs["rms_m_s"]
    for c in layout.COMPONENTS:  # float64 sums of the float32 blocks: equal to float32 round-off
        assert rms[c] == pytest.approx(float(np.sqrt(np.mean(data[c].astype(np.float64) ** 2))), rel=1e-12)
    # a value changed after the write (the writer's rms includes every value it writes, so a written value
    # can exceed it only sqrt(n) times): v at t 5, plane 1, y 2, z 0 in chunk file v/c/1/1/0/0 (t 4-7, raw)
    chunk = path / "v" / "c" / "1" / "1" / "0" / "0"
    values = np.fromfile(chunk, dtype="<f4")
    values[(1 * GRID.ny + 2) * GRID.nz + 0] = 101 * rms["v"]
    values.tofile(chunk)
    fs = open_store(path)
    with pytest.raises(StoreError, match=r"implausible value .* at v, plane index 1, t index 5, y index 2, z index 0 "
                                         r"\(beyond 100 x its rms .*chunk file v/c/1/1/0/0\)"):
        fs.check_chunks()
    fs.read_plane("v", 0)  # the other planes read


def test_read_span_of_any_time_range(tmp_path):
    # a span starting inside a chunk read the chunks after it shifted (rows left unread: issue 27 review)
    data = field()
    fs = open_store(write_store(tmp_path / "f.zarr", data, chunk_t=4))
    for t0 in range(GRID.nt):
        for t1 in range(t0 + 1, GRID.nt + 1):
            np.testing.assert_array_equal(fs.read_span("v", 1, t0, t1), data["v"][t0:t1, 1], err_msg=f"{t0}-{t1}")


def test_out_of_range_attributes_are_refused_on_open(tmp_path):
    path = write_store(tmp_path / "f.zarr", field())
    meta = json.loads((path / "zarr.json").read_text())
    meta["attributes"]["hub_height_m"] = 1e9
    (path / "zarr.json").write_text(json.dumps(meta))
    with pytest.raises(StoreError, match=r"is corrupted: attribute hub_height_m: hub height \(m\) = 1e\+09 is outside"):
        open_store(path)
