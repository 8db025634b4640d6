"""Raw chunk files by direct I/O (turbgen.store.chunk_files): the bytes on disk are the chunk's C-order bytes
whichever way they went (direct, through the bounce buffer, buffered fallback), a store written this way is
the store zarr would have written, and reads check the size."""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest
import zarr

from turbgen import oscalls
from turbgen.errors import StoreError
from turbgen.grid import Grid
from turbgen.store import open_store
from turbgen.store import writer as writer_module
from turbgen.store.chunk_files import empty_aligned, raw_chunk_path, read_chunk_file, write_chunk_file
from turbgen.store.checked_reads import read_checked
from turbgen.store.writer import create_store


def _arrays():
    rng = np.random.default_rng(5)
    aligned = empty_aligned((4, 32, 32))  # 16 KiB at a page boundary: written from its own memory
    aligned[...] = rng.standard_normal(aligned.shape)
    odd = rng.standard_normal((7, 31, 31)).astype(np.float32)  # 26908 bytes: through the bounce buffer
    strided = rng.standard_normal((31, 31, 7)).astype(np.float32).transpose(2, 0, 1)  # not C-contiguous
    return {"aligned": aligned, "odd": odd, "strided": strided}


@pytest.mark.parametrize("name", ["aligned", "odd", "strided"])
@pytest.mark.parametrize("direct", [True, False], ids=["direct", "buffered"])
def test_written_file_holds_the_c_order_bytes(tmp_path, monkeypatch, name, direct):
    if not direct:
        monkeypatch.setenv("TURBGEN_PORTABLE", "1")  # turbgen.oscalls: no O_DIRECT, buffered calls
    data = _arrays()[name]
    path = tmp_path / "a" / "c" / "0" / "0"
    path.parent.mkdir(parents=True)
    path.write_bytes(b"x" * 100_000)  # an older, longer file is replaced, not overwritten in part
    write_chunk_file(path, data)
    assert path.read_bytes() == np.ascontiguousarray(data).tobytes()
    back = np.empty(data.shape, np.float32)  # an ordinary (unaligned) array: read through the bounce buffer
    read_chunk_file(path, back)
    assert np.array_equal(back, data)
    back = empty_aligned(data.shape)
    read_chunk_file(path, back)
    assert np.array_equal(back, data)


def test_a_file_system_refusing_o_direct_gets_buffered_calls(tmp_path, monkeypatch):
    o_direct = oscalls.direct_io_flag()
    if not o_direct:
        pytest.skip("no O_DIRECT on this platform")
    real_open, refused = os.open, []

    def open_(path, flags, *args):
        if flags & o_direct:
            refused.append(path)
            raise OSError(errno.EINVAL, "Invalid argument")
        return real_open(path, flags, *args)

    monkeypatch.setattr(os, "open", open_)
    data = _arrays()["odd"]
    write_chunk_file(tmp_path / "f", data)
    back = np.empty_like(data)
    read_chunk_file(tmp_path / "f", back)
    assert len(refused) == 2 and np.array_equal(back, data)


def test_other_errors_are_not_swallowed(tmp_path, monkeypatch):
    def full(fd, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "write", full)
    with pytest.raises(OSError, match="No space"):
        write_chunk_file(tmp_path / "f", _arrays()["aligned"])


def test_read_refuses_a_file_of_the_wrong_size(tmp_path):
    (tmp_path / "f").write_bytes(b"\0" * 4000)
    with pytest.raises(ValueError, match="4000 bytes"):
        read_chunk_file(tmp_path / "f", np.empty(1024, np.float32))
    with pytest.raises(FileNotFoundError):
        read_chunk_file(tmp_path / "missing", np.empty(1024, np.float32))


ATTRS = {"model": "kaimal", "parameters": {"U_m_s": 10.0}, "units": {"U_m_s": "m s-1"}, "seed": 1, "U_m_s": 10.0,
         "hub_height_m": 90.0}


def _write_store(path, grid, planes, chunk_t):
    with create_store(path, grid, ATTRS, chunk_t=chunk_t) as w:
        for c in ("u", "v", "w"):
            for ix in range(grid.nx):
                w.write(c, ix, planes[c][:, ix])
    return path


def test_store_written_by_direct_io_is_the_one_zarr_writes(tmp_path, monkeypatch):
    """Chunk files byte for byte equal to zarr's own (whole chunks direct, the last shorter chunk by zarr
    with its fill-value padding), and read back equal through zarr and through read_checked."""
    grid = Grid(nt=70, dt_s=0.25, x_m=(0.0, 40.0), ny=5, nz=3, dy_m=2.0, dz_m=2.0)
    rng = np.random.default_rng(3)
    planes = {c: rng.standard_normal(grid.shape).astype(np.float32) for c in ("u", "v", "w")}
    direct = _write_store(tmp_path / "direct.zarr", grid, planes, chunk_t=32)
    monkeypatch.setattr(writer_module, "raw_chunk_path", lambda *a: None)
    plain = _write_store(tmp_path / "plain.zarr", grid, planes, chunk_t=32)
    files = sorted(p.relative_to(plain) for p in (plain / "u" / "c").rglob("*") if p.is_file())
    assert len(files) == 3 * 2  # chunks t 0-31, 32-63, 64-69 (padded to 32) of 2 planes
    for rel in files:
        assert (direct / rel).read_bytes() == (plain / rel).read_bytes(), rel
    monkeypatch.undo()
    fs = open_store(direct)
    arr = fs.array("v")
    assert raw_chunk_path(arr, (1, 1, 0, 0)) == direct / "v" / "c" / "1" / "1" / "0" / "0"
    assert np.array_equal(arr[:], planes["v"])
    assert np.array_equal(read_checked(arr, 1, 0, 70), planes["v"][:, 1])
    assert np.array_equal(read_checked(arr, 0, 32, 64, out=empty_aligned((32, 5, 3))), planes["v"][32:64, 0])


def test_truncated_raw_chunk_is_reported_as_corrupted(tmp_path):
    grid = Grid(nt=64, dt_s=0.25, x_m=(0.0,), ny=4, nz=4, dy_m=2.0, dz_m=2.0)
    planes = {c: np.ones(grid.shape, np.float32) for c in ("u", "v", "w")}
    path = _write_store(tmp_path / "s.zarr", grid, planes, chunk_t=32)
    chunk = path / "u" / "c" / "1" / "0" / "0" / "0"
    chunk.write_bytes(chunk.read_bytes()[:100])
    arr = zarr.open_group(str(path), mode="r")["u"]
    with pytest.raises(StoreError, match=r"corrupted chunk at u, plane index 0, t index 32-63"):
        read_checked(arr, 0, 0, 64)
