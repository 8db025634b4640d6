"""The pinned fields on an emulated other CPU: same seed, same field to float32 round-off.

A new process runs the pinned commands with numpy's SIMD dispatch limited to the x86-64-v2 baseline
(``NPY_DISABLE_CPU_FEATURES``: its float32 exp/sin/tanh kernels then round differently), OpenBLAS's kernels for
an older core (``OPENBLAS_CORETYPE``; the eigen-decompositions of the dense factors) and numba compiling for a
generic CPU (``NUMBA_CPU_NAME``, its own cache). It cannot emulate numpy's AVX-512 float64 kernels on a CPU
without them -- the ones whose 1-ulp differences of the cell tensors flipped eigenvector signs before the dense
factors became principal square roots (the same seed named another Mann field without AVX-512, correlation 0.85):
test_rounding_sensitivity perturbs those inputs by ulps directly, on any CPU.
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pinned_fields import PINNED

HERE = Path(__file__).parent
CASES = ["mann_default_ae", "kaimal_unstable_class_c"]
SCRIPT = """
import sys
from pathlib import Path
import numpy as np
sys.path.insert(0, {here!r})
from pinned_fields import make_field
out = {{}}
for name in {cases!r}:
    for key, value in make_field(name, Path({tmp!r})).items():
        out[name + "/" + key] = value
np.savez({out!r}, **out)
"""


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="emulates an older x86-64 CPU")
def test_pinned_fields_on_an_emulated_older_cpu(tmp_path):
    out = tmp_path / "fields.npz"
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES="X86_V3 X86_V4", OPENBLAS_CORETYPE="Nehalem",
               NUMBA_CPU_NAME="generic", NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    code = SCRIPT.format(here=str(HERE), cases=CASES, tmp=str(tmp_path), out=str(out))
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    with np.load(PINNED) as pinned, np.load(out) as got:
        for key in got.files:
            want = pinned[key]
            # float32 round-off of the accumulated FFTs and SIMD kernels: a changed stream or a flipped factor moves
            # values by O(1) standard deviations
            np.testing.assert_allclose(got[key], want, rtol=0, atol=1e-5 * float(np.std(want)) + 1e-12, err_msg=key)
