"""The constrained run's scratch file for the correction (turbgen.runs.correction_scratch)."""

from __future__ import annotations

import numpy as np

from turbgen.runs.correction_scratch import CorrectionScratch


def test_blocks_written_by_slab_group_read_back_by_plane_and_component(tmp_path):
    rng = np.random.default_rng(3)
    shape = (3, 3, 21, 4, 5)
    whole = (rng.normal(size=shape) + 1j * rng.normal(size=shape)).astype(np.complex64)
    with CorrectionScratch(tmp_path, shape) as scratch:
        for s0 in range(0, 21, 8):  # groups of 8 slabs and a shorter last one, as correction_blocks gives them
            slabs = range(s0, min(s0 + 8, 21))
            scratch.write(slabs, whole[:, :, slabs.start : slabs.stop])
        assert list(tmp_path.iterdir()) == []  # anonymous: nothing to clean up if the process dies
        for p in range(3):
            for c in range(3):
                np.testing.assert_array_equal(scratch.read(p, c), whole[p, c])
    assert list(tmp_path.iterdir()) == []


def test_size_is_that_of_the_complex64_spectra():
    assert CorrectionScratch.nbytes((11, 3, 2049, 64, 64)) == 11 * 3 * 2049 * 64 * 64 * 8


def test_reader_reads_ahead_in_the_given_order_and_refuses_another(tmp_path):
    import pytest

    rng = np.random.default_rng(4)
    shape = (3, 3, 9, 4, 5)
    whole = (rng.normal(size=shape) + 1j * rng.normal(size=shape)).astype(np.complex64)
    order = [(p, c) for p in (2, 0, 1) for c in range(3)]  # planes in time order, not storage order
    with CorrectionScratch(tmp_path, shape) as scratch:
        scratch.write(range(9), whole)
        read = scratch.reader(order)
        for p, c in order:
            np.testing.assert_array_equal(read(p, c), whole[p, c])
        with pytest.raises(ValueError, match="out of the order given"):
            read(0, 0)  # beyond the keys
        read = scratch.reader(order)
        with pytest.raises(ValueError, match="plane 0 component 0 asked for out of the order given"):
            read(0, 0)  # the first key is (2, 0)
