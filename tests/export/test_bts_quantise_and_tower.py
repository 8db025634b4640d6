"""The .bts int16 quantisation at and beyond its range, and the tower points down to (not onto) the ground."""

import numpy as np
import pytest

from turbgen.exporters.bts import int16_scaling, quantise, tower_heights


def test_int16_range_ends_and_saturation():
    # vmin and vmax map to the ends of the int16 range; values beyond it saturate instead of wrapping around
    slope, offset = int16_scaling(-3.0, 5.0)
    raw = quantise(np.array([-1e4, -3.0, 1.0, 5.0, 1e4]), slope, offset)
    assert raw.dtype == np.dtype("<i2")
    assert raw.tolist() == [-32768, -32768, int(np.rint(slope + offset)), 32767, 32767]


@pytest.mark.parametrize("bottom, dz, expected", [
    (30.0, 10.0, [30.0, 20.0, 10.0]),  # an exact multiple of dz: no point on the ground (z = 0)
    (0.1 * 3, 0.1, [0.3, 0.2, 0.1]),  # 0.30000000000000004 / 0.1 = 3.0000000000000004: still three points
    (25.0, 10.0, [25.0, 15.0, 5.0]),
    (0.0, 10.0, []),
])
def test_tower_heights_stop_above_the_ground(bottom, dz, expected):
    np.testing.assert_allclose(tower_heights(bottom, dz), expected, rtol=1e-12, atol=0.0)
