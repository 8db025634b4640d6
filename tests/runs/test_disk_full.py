"""A full disk under the runs' own files (issue 37 §2): the stencil cache is written with ordinary writes into
reserved space, never through a writable map of a sparse file (which a full disk turns into SIGBUS), and ENOSPC is
the usual one line (exit 2, ParameterError) with no temporary left."""

import errno
import subprocess
import sys

import numpy as np
import pytest

from turbgen.errors import ParameterError
from turbgen.runs import stencil_cache
from turbgen.synthesis.mann_stencil import BoxShape, build_stencil
from turbgen.theory.params import MannParams

BOX = BoxShape(nt=64, dx_m=4.0, nyp=12, nzp=10, dy_m=6.0, dz_m=5.0)
PARAMS = MannParams(ae=0.3, length_scale_m=30.0, gamma=3.2, evo_time_s=20.0)


def _leftovers(directory):
    return sorted(p.name for p in directory.iterdir())


def test_an_entry_built_in_several_batches_has_the_bits_of_one_build(tmp_path, monkeypatch):
    monkeypatch.setattr(stencil_cache, "ENTRY_BATCH_BYTES", 1)  # one step of 5 slabs per batch: 7 batches
    monkeypatch.setattr(stencil_cache, "build_step", lambda box: 5)
    builds = []
    monkeypatch.setattr(stencil_cache, "build_stencil", lambda *a, **k: builds.append(k["slabs"]) or build_stencil(*a, **k))
    got = stencil_cache.cached_stencil(PARAMS, BOX, tmp_path)
    assert builds == [(i, min(i + 5, BOX.nk1)) for i in range(0, BOX.nk1, 5)]
    want = build_stencil(PARAMS, BOX)
    assert np.array_equal(got.coef, want.coef) and np.array_equal(got.inv_tau, want.inv_tau)
    assert [p.suffix for p in tmp_path.iterdir()] == [".npy"]


@pytest.mark.parametrize("where", ["reserve", "write"])
def test_enospc_while_building_an_entry_is_one_line_and_leaves_nothing(tmp_path, monkeypatch, where):
    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(stencil_cache.oscalls if where == "reserve" else stencil_cache,
                        "reserve" if where == "reserve" else "write_at", full)  # fmt: skip
    with pytest.raises(ParameterError, match=r"stencil cache entry .*the disk is full .*stencil_cache") as err:
        stencil_cache.cached_stencil(PARAMS, BOX, tmp_path)
    assert "\n" not in str(err.value)
    assert _leftovers(tmp_path) == []


def test_a_stencil_larger_than_the_free_space_is_refused_before_writing(tmp_path, monkeypatch):
    monkeypatch.setattr("turbgen.resources.available_disk_bytes", lambda path: 1000)
    with pytest.raises(ParameterError, match=r"needs about .* of disk space but only 1000 B is free"):
        stencil_cache.cached_stencil(PARAMS, BOX, tmp_path)
    assert _leftovers(tmp_path) == []


def test_mann_with_a_stencil_cache_on_a_full_disk_exits_2_in_one_line(tmp_path, small_disk):
    """The reported case: a stencil cache on a nearly full file system gave "Bus error" (exit -7 / 135), leaving a
    sparse temporary entry; it must be one line, exit 2, nothing left in the cache or at --out."""
    disk = small_disk("2M")  # the entry of this box needs ~5.3 MiB
    out = tmp_path / "f.zarr"
    done = subprocess.run([sys.executable, "-c", "from turbgen.cli import main; main()", "mann", "--nt", "512", "--ny", "16", "--nz", "16",
                           "--planes", "0,50", "--out", str(out), "--stencil-cache", str(disk)],
                          capture_output=True, text=True, timeout=600)  # fmt: skip
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "stencil cache" in lines[0] and "disk" in lines[0], done.stderr
    assert _leftovers(disk) == [] and not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".f.zarr")]
