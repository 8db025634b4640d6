"""The same store and options give the same files on any machine, in any directory (issue 37 §4): no absolute path
in a written header (.bts description, InflowWind .dat title, HAWC2 .htc comment), and the .htc says where its box
names are relative to."""

from __future__ import annotations

import shutil

import pytest

import turbgen


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """One small store, copied to two directories of different absolute paths."""
    root = tmp_path_factory.mktemp("machines")
    first = root / "a" / "k.zarr"
    first.parent.mkdir()
    turbgen.kaimal(nt=32, ny=4, nz=4, planes=[0, 50], out=first)
    second = root / "b" / "deeper" / "k.zarr"
    second.parent.mkdir(parents=True)
    shutil.copytree(first, second)
    return root, first, second


@pytest.mark.parametrize("fmt, out", [("bts", "k.bts"), ("wnd", "k"), ("hawc2", "k")])
def test_exports_of_the_same_store_in_two_directories_are_identical(stores, fmt, out, monkeypatch):
    root, first, second = stores
    written = []
    for store in (first, second):
        monkeypatch.chdir(store.parent)
        result = turbgen.export(store.name, fmt, out, runner_files=True, overwrite=True)
        written.append({p.name: p.read_bytes() for p in map(store.parent.joinpath, result.paths)})
    assert sorted(written[0]) == sorted(written[1]) and len(written[0]) >= 2, sorted(written[0])
    for name, data in written[0].items():
        assert data == written[1][name], name
        assert str(root).encode() not in data, name  # no machine path in any file, binary headers included


def test_the_htc_says_its_box_names_are_relative_to_its_folder(stores, monkeypatch):
    _, first, _ = stores
    monkeypatch.chdir(first.parent)
    result = turbgen.export(first.name, "hawc2", "k", runner_files=True, overwrite=True)
    htc = next(p for p in map(first.parent.joinpath, result.paths) if p.suffix == ".htc").read_text()
    assert "relative to the folder of this file" in htc and "run HAWC2 in that folder" in htc
    assert "filename_u ./k_u.bin ;" in htc, htc
