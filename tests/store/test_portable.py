"""The portable fallbacks of turbgen.oscalls (issue 36 §5): with TURBGEN_PORTABLE=1 every Linux-only call
(renameat2, fallocate, /proc and cgroup reads, statvfs, O_DIRECT) takes the path of a system without it, and the
store and data-safety tests' key cases still pass."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import pytest

from turbgen import oscalls
from turbgen.store.temporaries import pid_alive, publish

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def portable(monkeypatch):
    monkeypatch.setenv(oscalls.PORTABLE_ENV, "1")
    assert oscalls.portable()


def test_the_linux_calls_are_used_here_unless_the_fallbacks_are_forced(tmp_path, monkeypatch):
    if not sys.platform.startswith("linux"):
        pytest.skip("the Linux-only calls exist on Linux only")
    monkeypatch.delenv(oscalls.PORTABLE_ENV, raising=False)
    assert oscalls.resident_bytes() > 0 and oscalls.meminfo_available_bytes() > 0
    (tmp_path / "a").write_text("a")
    assert oscalls.rename_noreplace(tmp_path / "a", tmp_path / "b") and (tmp_path / "b").read_text() == "a"


def test_every_fallback_is_taken_when_forced(tmp_path, portable):
    src, dst = tmp_path / "a", tmp_path / "b"
    src.write_text("new")
    dst.write_text("old")
    assert not oscalls.rename_noreplace(src, dst) and not oscalls.rename_exchange(src, dst)
    assert src.read_text() == "new" and dst.read_text() == "old"  # nothing done: the caller renames itself
    with open(src, "ab") as f:
        assert not oscalls.reserve(f.fileno(), 2**20, keep_size=True)
        assert not oscalls.reserve(f.fileno(), 2**20, keep_size=False)
    assert src.stat().st_size == 3  # nothing allocated
    assert oscalls.resident_bytes() is None and oscalls.meminfo_available_bytes() is None
    assert oscalls.cgroup_headroom_bytes() is None and oscalls.direct_io_flag() == 0
    assert oscalls.disk_free_bytes(tmp_path) == __import__("shutil").disk_usage(tmp_path).free
    assert pid_alive(os.getpid()) and not oscalls.is_zombie(os.getpid())


def test_publish_without_renameat2_never_clobbers_and_replaces_in_two_renames(tmp_path, portable):
    tmp, path = tmp_path / ".x.tmp-1", tmp_path / "x"
    tmp.write_text("one")
    assert publish(tmp, path, replace=False) is None and path.read_text() == "one"
    tmp.write_text("two")
    with pytest.raises(FileExistsError):
        publish(tmp, path, replace=False)
    old = publish(tmp, path, replace=True)
    assert path.read_text() == "two" and old is not None and old.read_text() == "one"


def test_a_reservation_the_system_cannot_make_checks_the_free_space(tmp_path, portable, monkeypatch):
    from turbgen.exporters import outputs

    target = tmp_path / "x.h5"
    monkeypatch.setattr(outputs, "available_disk_bytes", lambda path: 1000)
    with outputs.OutputSet([target], overwrite=False) as files:
        files.temp(target).write_bytes(b"")
        with pytest.raises(OSError) as err:
            files.reserve(target, 2000)
        assert err.value.errno == errno.ENOSPC
        files.reserve(target, 500)  # fits: nothing to refuse
    assert target.exists()


# not the zombie case: without /proc a killed, unreaped writer counts as alive (its temporary is left, never a
# live writer's removed); not the renameat2 variant of the racing overwrites (the same as two-renames here)
KEY_CASES = ("full_disk or two-renames or publish_killed or dead_writers or enospc or batches or declines "
             "or raw_and_zarr_paths")


def test_the_key_store_and_safety_cases_pass_with_the_fallbacks_forced():
    """The full-disk, atomic-publication and dead-writer cases of tests/store/test_data_safety.py, a store written
    and read through zarr (the raw-chunk path declines without O_DIRECT) and the stencil cache's
    tests/runs/test_disk_full.py, run again in a child pytest with TURBGEN_PORTABLE=1."""
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider", "-k", KEY_CASES,
                           "tests/store/test_data_safety.py", "tests/store/test_chunk_files.py",
                           "tests/runs/test_disk_full.py"],
                          cwd=ROOT, capture_output=True, text=True, timeout=900,
                          env={**os.environ, oscalls.PORTABLE_ENV: "1"})  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert " passed" in done.stdout and " failed" not in done.stdout
