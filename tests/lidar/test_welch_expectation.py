"""The expected Welch estimate of line spectra: against a brute-force segment DFT, and the interpolation."""

import numpy as np
import pytest

from turbgen.virtual_lidar.description import PRESETS
from turbgen.virtual_lidar.welch_expectation import expected_welch, theory_nodes, weigh_lines
from turbgen.spec.preset_runs import mann_params_for
from turbgen.theory.lidar_lattice import BoxLattice
from turbgen.theory.lidar_preview import PreviewSpectra, mann_preview_spectra
from turbgen.validation.estimators import WelchSetup

SETUP = WelchSetup(64, 0.25)
RECORD_S = 128.0  # 8 lines per Welch bin


def _brute_force(S: PreviewSpectra, bins):
    """E[Welch] by the explicit segment DFT of every line +-f_j (Hann window, segment mean removed)."""
    n = SETUP.nperseg
    t = np.arange(n) * SETUP.dt_s
    out = []
    for m in bins:
        k = []
        for sign in (1.0, -1.0):
            e = np.exp(2j * np.pi * sign * S.f_hz[:, None] * t[None, :])
            e = (e - e.mean(axis=1, keepdims=True)) * SETUP.window
            k.append(np.abs(e @ np.exp(-2j * np.pi * m * np.arange(n) / n)) ** 2)
        c = SETUP.scale[m] / (2 * RECORD_S)
        out.append([c * (k[0] + k[1]) @ S.S_RR, c * (k[0] + k[1]) @ S.S_LL,
                    c * (k[0] @ S.S_RL + k[1] @ np.conj(S.S_RL))])
    return np.array(out)


def test_line_weights_match_the_segment_dft_and_a_flat_spectrum_is_unbiased():
    bins = np.arange(1, 9)
    f_bins = bins / (SETUP.nperseg * SETUP.dt_s)
    nodes, lines = theory_nodes(f_bins, SETUP, RECORD_S)
    assert lines[0] == 1 / RECORD_S and lines[-1] == pytest.approx((8 + 6) / 16)
    rng = np.random.default_rng(3)
    S = PreviewSpectra(lines, 1 + rng.random(lines.size), 1 + rng.random(lines.size),
                       rng.random(lines.size) + 1j * rng.random(lines.size))
    exact = _brute_force(S, bins)
    got = weigh_lines(S.S_RR, S.S_LL, S.S_RL, lines, f_bins, SETUP, RECORD_S)
    for a, b in zip(got, exact.T):
        np.testing.assert_allclose(a, b, rtol=1e-9)
    ones = PreviewSpectra(nodes, np.ones(nodes.size), np.ones(nodes.size), 0.5 * np.ones(nodes.size) + 0j)
    flat = expected_welch(ones, f_bins, SETUP, RECORD_S)
    # white noise: unbiased from bin 2 (to the Hann leakage of the lines beyond the last bin + 6, < 1e-5);
    # bin 1 loses the share of the segment mean
    np.testing.assert_allclose(flat.S_RR[1:], 1.0, rtol=1e-5)
    assert flat.S_RR[0] < 0.9


def test_bin_centre_nodes_interpolate_the_lines():
    """Theory at the nodes (lines below bin 2, bin centres above) gives the same gamma^2 as at every line."""
    meas = PRESETS["nacelle-4beam"].measurement_points()
    p = mann_params_for("neutral", 16.0)
    setup, record = WelchSetup(256, 0.25), 512.0
    box = BoxLattice(64, 64, 4.7, 4.7, record)
    f_bins = np.arange(1, 7) / 64
    nodes, lines = theory_nodes(f_bins, setup, record)
    assert nodes.size < lines.size / 3
    a = expected_welch(mann_preview_spectra(nodes, meas, p, 16.0, 63.0, box=box), f_bins, setup, record)
    S = mann_preview_spectra(lines, meas, p, 16.0, 63.0, box=box)
    b = weigh_lines(S.S_RR, S.S_LL, S.S_RL, lines, f_bins, setup, record)
    np.testing.assert_allclose(a.coh2_RL, np.abs(b[2]) ** 2 / (b[0] * b[1]), atol=3e-4)
    # the window matters: 1/32 Hz sits ~0.03 above the theory at its centre
    centre = mann_preview_spectra(f_bins, meas, p, 16.0, 63.0, box=box).coh2_RL
    assert a.coh2_RL[1] - centre[1] > 0.02
