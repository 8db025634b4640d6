"""The console-script entry point: start-up imports frozen out of the cyclic collector, collector on after."""

from __future__ import annotations

import subprocess
import sys

import pytest

PROBE = """
import gc, sys
from turbgen.cli import main
sys.argv = ["turbgen", *sys.argv[1:]]
try:
    main()
except SystemExit:
    pass
print(gc.isenabled(), gc.get_freeze_count(), *sorted(m for m in ("dask", "numba", "zarr") if m in sys.modules))
"""


@pytest.mark.parametrize("args, frozen", [(["info", "--help"], True), (["--version"], False)])
def test_main_freezes_the_command_imports_and_leaves_the_collector_on(args, frozen):
    out = subprocess.run([sys.executable, "-c", PROBE, *args], capture_output=True, text=True, check=True).stdout
    enabled, count = out.splitlines()[-1].split()[:2]
    assert enabled == "True"
    # importing a command's module creates > 10^4 long-lived objects (click, numpy, turbgen); --version imports none
    assert (int(count) > 10_000) if frozen else (int(count) == 0), out


@pytest.mark.parametrize("command", ["mann", "kaimal", "validate", "info", "transient", "lidar", "export"])
def test_help_loads_none_of_the_work_s_modules(command):
    """--help of a command that makes or reads fields is quick: numba, zarr and dask load when its work starts."""
    out = subprocess.run([sys.executable, "-c", PROBE, command, "--help"], capture_output=True, text=True, check=True)
    assert out.stdout.splitlines()[-1].split()[2:] == [], out.stdout.splitlines()[-1]


def test_the_export_command_offers_every_exporter():
    """turbgen export lists its formats without importing the exporters (--help above): the same names, in order."""
    from turbgen.cli.export import FORMATS
    from turbgen.exporters import EXPORTERS

    assert FORMATS == tuple(EXPORTERS)


@pytest.mark.parametrize("args", [["mann", "--L", "5000"], ["kaimal", "--U", "500"], ["mann", "--gamma", "99"]])
def test_a_bad_value_is_refused_before_the_run_s_modules_load(args, tmp_path):
    """A typo answers as quickly as --help: the run is checked (turbgen.spec.run_inputs) before its imports."""
    out = subprocess.run([sys.executable, "-c", PROBE, *args], cwd=tmp_path, capture_output=True, text=True,
                         check=True)  # fmt: skip
    assert "outside the allowed range" in out.stderr, out.stderr
    assert out.stdout.splitlines()[-1].split()[2:] == [], out.stdout.splitlines()[-1]
    assert not any(tmp_path.iterdir())


def test_the_imports_a_command_makes_when_it_runs_are_frozen_too(tmp_path):
    """turbgen.cli.run_imports: a run's own imports (numba, zarr: > 10^5 objects) join the permanent generation."""
    def last_line(*args):
        done = subprocess.run([sys.executable, "-c", PROBE, "mann", *args], cwd=tmp_path, capture_output=True,
                              text=True, check=True)  # fmt: skip
        return done.stdout.splitlines()[-1].split()

    helped, ran = last_line("--help"), last_line("--nt", "64", "--ny", "4", "--nz", "4", "--planes", "0", "--ae",
                                                 "0.1", "--out", "f.zarr")  # fmt: skip
    assert ran[0] == "True" and {"numba", "zarr"} <= set(ran[2:]), ran  # the run loaded its work's modules
    assert int(ran[1]) > int(helped[1]) + 50_000, (helped, ran)


BLAS_PROBE = """
import os, sys
from turbgen.cli import main
sys.argv = ["turbgen", "--version"]
try:
    main()
except SystemExit:
    pass
import numpy  # loads OpenBLAS after main() set its default
print(os.environ["OPENBLAS_NUM_THREADS"])
"""


@pytest.mark.parametrize("given, expected", [(None, "1"), ("2", "2")])
def test_main_keeps_openblas_to_one_thread_unless_the_user_says_otherwise(given, expected):
    import os

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    out = subprocess.run([sys.executable, "-c", BLAS_PROBE], capture_output=True, text=True, check=True, env=env)
    assert out.stdout.split()[-1] == expected


LEAN = """
import sys
sys.modules["xarray"] = sys.modules["pandas"] = None  # as if not installed: importing either raises ImportError
from turbgen.cli import main
sys.argv = ["turbgen", *sys.argv[1:]]
main()
"""


@pytest.mark.parametrize("model", ["mann", "kaimal"])
def test_a_command_that_writes_a_store_needs_neither_xarray_nor_pandas(tmp_path, model):
    """Start-up: xarray and pandas (~0.5 s of CPU) come with the Python API's Datasets only (turbgen.api.fields)."""
    args = [model, "--nt", "64", "--ny", "4", "--nz", "4", "--planes", "0", "--out", "f.zarr"]
    res = subprocess.run([sys.executable, "-c", LEAN, *args, *(["--ae", "0.1"] if model == "mann" else [])],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)  # fmt: skip
    assert res.returncode == 0, res.stderr[-2000:]
    assert (tmp_path / "f.zarr" / "zarr.json").exists()
