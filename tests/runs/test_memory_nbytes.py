"""The memory estimates of the runs are the bytes their synthesis objects really allocate (one source: the shapes)."""

from __future__ import annotations

import pytest

from turbgen.grid import Grid
from turbgen.runs.kaimal import kaimal_generator, memory_needed, ring_planes, spectrum_bytes
from turbgen.runs.mann import build_mann_stencil
from turbgen.spec.kaimal import KaimalRun, kaimal_params
from turbgen.spec.mann import MannRun
from turbgen.synthesis import mann_spacetime as ms
from turbgen.synthesis.kaimal_evo import InMemorySpectrum, PlaneRing
from turbgen.synthesis.mann_stencil import build_stencil, synthesis_box


@pytest.mark.parametrize("planes", [[0.0, 50.0, 100.0], [0.0]])
def test_mann_snapshots_allocate_what_they_report(planes):
    run = MannRun.from_mapping({"grid": {"nt": 64, "ny": 6, "nz": 5, "x_m": planes}})
    gen = ms.MannSnapshots(build_mann_stencil(run), 6, 5, threads=2, buffers=2)
    assert gen.nbytes == 0
    for _ in gen.generate(run.seed, run.plane_times_s()):
        pass
    assert gen.nbytes == ms.MannSnapshots.bytes_needed(synthesis_box(run), 6, 5, len(planes), 2, buffers=2) > 0


def test_on_demand_stencil_adds_its_coefficients_and_their_temporaries():
    run = MannRun.from_mapping({"grid": {"nt": 64, "ny": 6, "nz": 5, "x_m": [0.0]}})
    box = synthesis_box(run)
    gen = ms.MannSnapshots(build_stencil(run.params, box, storage="on_demand"), 6, 5, threads=2)
    for _ in gen.generate(run.seed, run.plane_times_s()):
        pass
    temporaries = 2 * ms.TASK_SLABS * box.nk2_half * box.nzp * ms._COEF_TEMP_BYTES
    assert gen.nbytes == ms.MannSnapshots.bytes_needed(box, 6, 5, 1, 2, coefficients=True) - temporaries


def test_kaimal_buffers_allocate_what_memory_needed_counts():
    grid = Grid(128, 0.5, (0.0, 50.0, 100.0), 4, 3, 10.0, 10.0)
    run = KaimalRun(kaimal_params(16.0, "A", 90.0), grid, 16.0, 3, turb_class="A")
    gen = kaimal_generator(run, workers=1)
    spectrum = InMemorySpectrum(grid.nx, gen.nf, grid.ny, grid.nz)
    ring = PlaneRing(grid.nt, grid.ny, grid.nz, ring_planes(grid))
    for c in "vwu":
        for _ in gen.component_planes(c, spectrum=spectrum, ring=ring):
            pass
    assert spectrum.nbytes == spectrum_bytes(grid)
    assert ring.nbytes == PlaneRing.bytes_needed(grid.nt, grid.ny, grid.nz, ring.size)
    transform = 3 * gen.nf * grid.ny * grid.nz * 8  # the spectrum copies of the two planes transformed at once
    sampler = gen.sampler_bytes()
    assert memory_needed(grid, sampler=sampler) == spectrum.nbytes + ring.nbytes + max(transform, sampler)
