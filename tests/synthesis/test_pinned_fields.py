"""The fields of a few fixed commands are pinned (tests/synthesis/data/pinned_fields.npz): a refactor must not
change a single bit of them.

Bit identity holds for one build of numpy/scipy/pyfftw on CPUs with AVX2 and FMA, AVX-512 ones included
(pinned_fields.fingerprint); on an older CPU (numpy's baseline SIMD exp/sin kernels round differently) or other
library builds the fields must agree to float32 round-off: a few ulps
of the accumulated FFT, bounded here by 1e-5 of the component's standard deviation (a changed seed
stream, parameter or normalisation moves values by O(1) standard deviations). The fields were pinned with the
default FFT backend (pyfftw); under another (TURBGEN_FFT_BACKEND=scipy) they are compared the same way, to
round-off (test_fft_backends derives the bound of a backend's difference, well inside this one).
"""

from __future__ import annotations

import numpy as np
import pytest

from pinned_fields import CASES, PINNED, fingerprint, make_field

from turbgen import fft


@pytest.fixture(scope="module")
def pinned():
    with np.load(PINNED) as data:
        return dict(data)


@pytest.mark.parametrize("name", list(CASES))
def test_field_is_the_pinned_one(name, pinned, tmp_path):
    got = make_field(name, tmp_path)
    exact = str(pinned["fingerprint"]) == fingerprint() and fft.current() == fft.DEFAULT
    for key, value in got.items():
        want = pinned[f"{name}/{key}"]
        assert value.dtype == want.dtype and value.shape == want.shape, key
        if exact:
            assert np.array_equal(value, want), f"{name}/{key} differs from the pinned field"
        else:
            np.testing.assert_allclose(value, want, rtol=0, atol=1e-5 * float(np.std(want)) + 1e-12,
                                       err_msg=f"{name}/{key} (fingerprint or FFT backend differs: round-off check)")
