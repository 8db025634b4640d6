"""The raw-chunk fast path (turbgen.store.chunk_files) against zarr's own I/O: the same chunk files and the same
arrays whichever way the bytes went (direct from the caller's memory, through the bounce buffer, or through zarr
where the fast path declines), and reads check the file's size."""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest
import zarr

from turbgen import oscalls
from turbgen.errors import StoreError
from turbgen.grid import Grid
from turbgen.store import chunk_files, open_store
from turbgen.store.chunk_files import empty_aligned, raw_chunk_path, read_chunk, write_chunk
from turbgen.store.checked_reads import read_checked
from turbgen.store.writer import create_store


def _arrays():
    rng = np.random.default_rng(5)
    aligned = empty_aligned((4, 32, 32))  # 16 KiB at a page boundary: written from its own memory
    aligned[...] = rng.standard_normal(aligned.shape)
    odd = rng.standard_normal((7, 31, 31)).astype(np.float32)  # 26908 bytes: through the bounce buffer
    strided = rng.standard_normal((31, 31, 7)).astype(np.float32).transpose(2, 0, 1)  # not C-contiguous
    return {"aligned": aligned, "odd": odd, "strided": strided}


def _raw_array(root, shape):
    return zarr.create_array(str(root), shape=(2, *shape), chunks=(1, *shape), dtype="float32", compressors=None,
                             fill_value=np.nan)  # fmt: skip


@pytest.mark.parametrize("name", ["aligned", "odd", "strided"])
def test_chunk_file_is_the_one_zarr_writes_and_reads_back(tmp_path, name):
    if not oscalls.direct_io_flag():
        pytest.skip("no O_DIRECT here: the fast path declines (tested below)")
    data = _arrays()[name]
    raw, plain = _raw_array(tmp_path / "raw", data.shape), _raw_array(tmp_path / "plain", data.shape)
    path = raw_chunk_path(raw, (1, 0, 0, 0))
    path.parent.mkdir(parents=True)
    path.write_bytes(b"x" * 100_000)  # an older, longer file is replaced, not overwritten in part
    assert write_chunk(raw, (1, 0, 0, 0), data)
    plain[1] = data
    assert path.read_bytes() == raw_chunk_path(plain, (1, 0, 0, 0)).read_bytes() == np.ascontiguousarray(data).tobytes()
    for back in (np.empty(data.shape, np.float32), empty_aligned(data.shape)):  # bounce buffer, then direct
        assert read_chunk(plain, (1, 0, 0, 0), back) and np.array_equal(back, data)
    assert np.array_equal(raw[1], data)


def test_the_fast_path_declines_where_it_cannot_apply(tmp_path, monkeypatch):
    """A compressed array, RAW off, no O_DIRECT (forced fallbacks) and a file system refusing it: False, nothing
    written, so the caller goes through zarr."""
    data = _arrays()["odd"]
    packed = zarr.create_array(str(tmp_path / "z"), shape=(2, *data.shape), chunks=(1, *data.shape), dtype="float32")
    assert raw_chunk_path(packed, (0, 0, 0, 0)) is None and not write_chunk(packed, (0, 0, 0, 0), data)
    raw = _raw_array(tmp_path / "raw", data.shape)
    monkeypatch.setattr(chunk_files, "RAW", False)
    assert not write_chunk(raw, (0, 0, 0, 0), data)
    monkeypatch.undo()
    monkeypatch.setenv(oscalls.PORTABLE_ENV, "1")
    assert not write_chunk(raw, (0, 0, 0, 0), data) and not read_chunk(raw, (0, 0, 0, 0), data.copy())
    monkeypatch.undo()
    o_direct, real_open = oscalls.direct_io_flag(), os.open
    if not o_direct:
        pytest.skip("no O_DIRECT on this platform")

    def open_(path, flags, *args):
        if flags & o_direct:
            raise OSError(errno.EINVAL, "Invalid argument")
        return real_open(path, flags, *args)

    monkeypatch.setattr(os, "open", open_)
    assert not write_chunk(raw, (0, 0, 0, 0), data)
    assert not raw_chunk_path(raw, (0, 0, 0, 0)).exists()


def test_other_errors_are_not_swallowed(tmp_path, monkeypatch):
    if not oscalls.direct_io_flag():
        pytest.skip("no O_DIRECT on this platform")

    def full(fd, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    data = _arrays()["aligned"]
    raw = _raw_array(tmp_path / "raw", data.shape)
    monkeypatch.setattr(os, "write", full)
    with pytest.raises(OSError, match="No space"):
        write_chunk(raw, (0, 0, 0, 0), data)


def test_read_refuses_a_file_of_the_wrong_size(tmp_path):
    if not oscalls.direct_io_flag():
        pytest.skip("no O_DIRECT on this platform")
    raw = _raw_array(tmp_path / "raw", (1024,))
    path = raw_chunk_path(raw, (0, 0))
    path.parent.mkdir(parents=True)
    path.write_bytes(b"\0" * 4000)
    with pytest.raises(ValueError, match="4000 bytes"):
        read_chunk(raw, (0, 0), np.empty(1024, np.float32))
    with pytest.raises(FileNotFoundError):
        read_chunk(raw, (1, 0), np.empty(1024, np.float32))


ATTRS = {"model": "kaimal", "parameters": {"U_m_s": 10.0}, "units": {"U_m_s": "m s-1"}, "seed": 1, "U_m_s": 10.0,
         "hub_height_m": 90.0}


def _write_store(path, grid, planes, chunk_t):
    with create_store(path, grid, ATTRS, chunk_t=chunk_t) as w:
        for c in ("u", "v", "w"):
            for ix in range(grid.nx):
                w.write(c, ix, planes[c][:, ix])
    return path


def test_raw_and_zarr_paths_give_the_same_store_and_reads(tmp_path, monkeypatch):
    """The store written with the fast path (whole chunks; the last, shorter chunk by zarr with its fill-value
    padding) has zarr's chunk files byte for byte, and read_checked reads the same arrays both ways."""
    grid = Grid(nt=70, dt_s=0.25, x_m=(0.0, 40.0), ny=5, nz=3, dy_m=2.0, dz_m=2.0)
    rng = np.random.default_rng(3)
    planes = {c: rng.standard_normal(grid.shape).astype(np.float32) for c in ("u", "v", "w")}
    direct = _write_store(tmp_path / "direct.zarr", grid, planes, chunk_t=32)
    monkeypatch.setattr(chunk_files, "RAW", False)
    plain = _write_store(tmp_path / "plain.zarr", grid, planes, chunk_t=32)
    files = sorted(p.relative_to(plain) for p in (plain / "u" / "c").rglob("*") if p.is_file())
    assert len(files) == 3 * 2  # chunks t 0-31, 32-63, 64-69 (padded to 32) of 2 planes
    for rel in files:
        assert (direct / rel).read_bytes() == (plain / rel).read_bytes(), rel
    arr = open_store(direct).array("v")
    through_zarr = [read_checked(arr, ix, 0, 70) for ix in (0, 1)]
    monkeypatch.undo()
    assert raw_chunk_path(arr, (1, 1, 0, 0)) == direct / "v" / "c" / "1" / "1" / "0" / "0"
    assert np.array_equal(arr[:], planes["v"])
    for ix in (0, 1):
        assert np.array_equal(read_checked(arr, ix, 0, 70), through_zarr[ix])
        assert np.array_equal(through_zarr[ix], planes["v"][:, ix])
    assert np.array_equal(read_checked(arr, 0, 32, 64, out=empty_aligned((32, 5, 3))), planes["v"][32:64, 0])


def test_a_compressed_store_goes_through_zarr_and_reads_the_same(tmp_path, monkeypatch):
    """Blosc-lz4 + shuffle, the codec of older stores: the fast path declines and zarr writes and reads it."""
    from zarr.codecs import BloscCodec

    from turbgen.store import layout

    grid = Grid(nt=64, dt_s=0.25, x_m=(0.0, 40.0), ny=4, nz=4, dy_m=2.0, dz_m=2.0)
    planes = {c: np.random.default_rng(7).standard_normal(grid.shape).astype(np.float32) for c in ("u", "v", "w")}
    monkeypatch.setattr(layout, "compressor", lambda: BloscCodec(cname="lz4", shuffle="shuffle"))
    packed = open_store(_write_store(tmp_path / "packed.zarr", grid, planes, chunk_t=32))
    assert packed.array("u").compressors and raw_chunk_path(packed.array("u"), (0, 0, 0, 0)) is None
    for c in ("u", "v", "w"):
        for ix in (0, 1):
            assert np.array_equal(packed.read_plane(c, ix), planes[c][:, ix])


@pytest.mark.parametrize("raw", [True, False], ids=["raw", "zarr"])
def test_truncated_chunk_is_reported_as_corrupted(tmp_path, monkeypatch, raw):
    monkeypatch.setattr(chunk_files, "RAW", raw)
    grid = Grid(nt=64, dt_s=0.25, x_m=(0.0,), ny=4, nz=4, dy_m=2.0, dz_m=2.0)
    planes = {c: np.ones(grid.shape, np.float32) for c in ("u", "v", "w")}
    path = _write_store(tmp_path / "s.zarr", grid, planes, chunk_t=32)
    chunk = path / "u" / "c" / "1" / "0" / "0" / "0"
    chunk.write_bytes(chunk.read_bytes()[:100])
    arr = zarr.open_group(str(path), mode="r")["u"]
    with pytest.raises(StoreError, match=r"corrupted chunk at u, plane index 0, t index 32-63"):
        read_checked(arr, 0, 0, 64)
