"""The same fields under every OpenBLAS kernel this machine can run (``OPENBLAS_CORETYPE`` in child processes), so a
CPU dependence shows here before it reaches another machine (an AVX-512 one runs the SkylakeX kernels, an AVX2 one
Haswell's).

What holds, and is asserted:

- Mann fields: bit-identical under every kernel (their dense factors' eigen-decompositions do not reach the last
  bit of the float32 field), and equal to the pinned fields when the library builds are the pinned ones.
- The virtual lidar's record of a field, and a lidar record placed from its CSV copy: bit-identical (fixed-order
  sums, turbgen.virtual_lidar.sampling.weighted_sum); the dependent-measurement refusal names the same measurements.
- Kaimal fields: the planes are mixed by a float32 matrix product (OpenBLAS sgemm), and fields conditioned on data
  go through dense float64 solves: to float32 round-off on another kernel, bounded as in test_pinned_fields by 1e-5
  of the component's standard deviation (a changed stream or parameter moves values by O(1) standard deviations).
"""

from __future__ import annotations

import os
import platform
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pinned_fields import CASES, PINNED, fingerprint

from turbgen import fft

HERE = Path(__file__).parent
CANDIDATES = ("SkylakeX", "Haswell", "Sandybridge", "Prescott")  # AVX-512, AVX2, AVX, SSE3 kernels
MANN = [name for name in CASES if name.startswith("mann")]

pytestmark = pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="OpenBLAS x86-64 core types")


def _core(extra: dict) -> str | None:
    """The core type OpenBLAS runs with ``extra`` in the environment (None: its kernels crash on this CPU, e.g. SkylakeX's
    AVX-512 instructions without AVX-512: the probe runs them)."""
    env = dict(os.environ, OPENBLAS_VERBOSE="2", **extra)
    probe = "import numpy as np; a = np.ones((64, 64)); np.linalg.eigh(a @ a); (a.astype(np.float32) @ a.astype(np.float32))"
    res = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, timeout=60)
    found = re.search(r"Core: (\w+)", res.stdout + res.stderr)
    return found.group(1) if res.returncode == 0 and found else None


def _run(extra: dict, directory: Path) -> dict:
    directory.mkdir()
    out = directory / "out.npz"
    res = subprocess.run([sys.executable, str(HERE / "cpu_kernel_cases.py"), str(out), str(directory)],
                         env=dict(os.environ, **extra), capture_output=True, text=True, timeout=900)  # fmt: skip
    assert res.returncode == 0, (res.stdout + res.stderr)[-3000:]
    with np.load(out) as data:
        return dict(data)


@pytest.fixture(scope="module")
def kernels(tmp_path_factory) -> dict[str, dict]:
    native = _core({})
    if native is None:
        pytest.skip("numpy's BLAS reports no OpenBLAS core type (OPENBLAS_VERBOSE)")
    names, seen = {"native " + native: {}}, {native}
    for core in CANDIDATES:
        got = _core({"OPENBLAS_CORETYPE": core})
        if got is not None and got not in seen:
            names[got], seen = {"OPENBLAS_CORETYPE": core}, seen | {got}
    if len(names) < 2:
        pytest.skip(f"OpenBLAS offers no kernel besides {native} here")
    base = tmp_path_factory.mktemp("kernels")
    return {name: _run(extra, base / name.replace(" ", "_")) for name, extra in names.items()}


def _reference(kernels: dict) -> dict:
    with np.load(PINNED) as pinned:  # pinned with the default FFT backend
        if str(pinned["fingerprint"]) == fingerprint() and fft.current() == fft.DEFAULT:
            return dict(pinned)
    return next(iter(kernels.values()))  # other library builds or FFT backends: the native kernel's fields


def _close(got, want, key):
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * float(np.std(want)) + 1e-12, err_msg=key)


def test_mann_fields_are_bit_identical_under_every_kernel(kernels):
    ref = _reference(kernels)
    for kernel, got in kernels.items():
        for key in (k for k in got if k.split("/")[0] in MANN):
            assert np.array_equal(got[key], ref[key]), f"{key} under {kernel}"


def test_kaimal_fields_agree_to_float32_round_off(kernels):
    ref = _reference(kernels)
    for got in kernels.values():
        for key in (k for k in got if k.split("/")[0] in CASES and k.split("/")[0] not in MANN):
            _close(got[key], ref[key], key)


def test_lidar_records_placements_and_refusals_are_the_same_bits(kernels):
    first = next(iter(kernels.values()))
    assert "linearly dependent" in str(first["refusal"]), str(first["refusal"])
    for kernel, got in kernels.items():
        assert bool(got["csv_places_the_same_bits"]), kernel
        assert np.array_equal(got["lidar/v_los"], first["lidar/v_los"]), kernel
        assert str(got["refusal"]) == str(first["refusal"]), kernel


def test_constrained_fields_agree_to_float32_round_off(kernels):
    first = next(iter(kernels.values()))
    for got in kernels.values():
        for c in "uvw":
            _close(got[f"constrained/{c}"], first[f"constrained/{c}"], f"constrained/{c}")
