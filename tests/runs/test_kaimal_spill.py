"""Kaimal runs whose spectrum does not fit in memory: the spectrum goes to a scratch file, same field."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from dataclasses import replace

import numpy as np
import pytest

from turbgen.grid import Grid
from turbgen.runs import kaimal as runs_kaimal
from turbgen.runs.kaimal import memory_needed, run_kaimal, spectrum_bytes
from turbgen.spec.kaimal import KaimalRun, kaimal_params
from turbgen.store import open_store

GRID = Grid(256, 0.5, (0.0, 50.0, 63.3, 76.6), 5, 4, 10.0, 10.0)


def _run(**kw):
    return KaimalRun(kaimal_params(16.0, "A", 90.0), GRID, 16.0, 3, turb_class="A", long_components="uvw", **kw)


def test_spilled_spectrum_gives_the_same_field(tmp_path):
    a = run_kaimal(_run(), tmp_path / "mem.zarr", spill=False)
    b = run_kaimal(_run(), tmp_path / "file.zarr", spill=True)
    assert (a["spilled"], b["spilled"]) == (False, True)
    fa, fb = open_store(a["path"]), open_store(b["path"])
    for c in "uvw":
        assert np.array_equal(fa.array(c)[:], fb.array(c)[:])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.zarr", "mem.zarr"]  # no scratch file left


def test_spill_is_chosen_when_the_spectrum_does_not_fit(tmp_path, monkeypatch):
    # pretend only a little more memory than the spilled run needs is available (its yz samplers included)
    sampler = runs_kaimal.kaimal_generator(_run()).sampler_bytes()
    available = memory_needed(GRID, spill=True, sampler=sampler) + 1024
    assert memory_needed(GRID, sampler=sampler) > 0.8 * available
    monkeypatch.setattr(runs_kaimal, "available_memory_bytes", lambda: available)
    monkeypatch.setattr("turbgen.resources.available_memory_bytes", lambda: available)
    s = run_kaimal(_run(), tmp_path / "auto.zarr")
    assert s["spilled"] is True


def test_spilled_memory_does_not_grow_with_the_number_of_planes():
    g11 = replace(GRID, nt=4096, x_m=tuple(float(x) for x in range(0, 110, 10)), ny=31, nz=31)
    g44 = replace(g11, x_m=tuple(float(x) for x in range(0, 440, 10)))
    # in memory the spectrum grows with the planes; spilled only the 32-bin chunk does
    assert memory_needed(g44) - memory_needed(g11) == spectrum_bytes(g44) - spectrum_bytes(g11)
    grow = memory_needed(g44, spill=True) - memory_needed(g11, spill=True)
    assert grow == 3 * 33 * 32 * 31 * 31 * 8 and grow < 0.05 * spectrum_bytes(g44)


@pytest.mark.slow
def test_spilled_run_peak_memory_is_lower_by_about_the_spectrum(tmp_path):
    # the default 4096 x 11 x 31 x 31 run in fresh processes: peak RSS with the spectrum in memory
    # vs in the scratch file; the difference must be most of the 173 MB spectrum
    code = textwrap.dedent(
        """
        import sys
        from turbgen.runs.kaimal import run_kaimal
        from turbgen.spec.kaimal import KaimalRun
        run_kaimal(KaimalRun.from_mapping({}), sys.argv[1], spill=sys.argv[2] == "1", threads=1)
        # VmHWM is this process image's own peak (ru_maxrss can carry the forking parent's peak over exec)
        status = open("/proc/self/status").read().split("VmHWM:")[1]
        print(int(status.split()[0]) * 1024)
        """
    )
    rss = {}
    for spill in ("0", "1"):
        out = subprocess.run([sys.executable, "-c", code, str(tmp_path / f"s{spill}.zarr"), spill],
                             capture_output=True, text=True, check=True)  # fmt: skip
        rss[spill] = int(out.stdout.split()[-1])
    spectrum = spectrum_bytes(KaimalRun.from_mapping({}).grid)
    assert rss["0"] - rss["1"] > 0.6 * spectrum, (rss, spectrum)
