"""Kaimal/IEC closed forms, coherence models and the Kaimal REWS spectrum (Eq. 11, 12, 18, 25)."""

import numpy as np
import pytest
from scipy.integrate import quad

from turbgen.errors import ParameterError
from turbgen.theory.coherence_models import (
    exponential_longitudinal,
    exponential_yz,
    kristensen,
    simley_pao_parameters,
)
from turbgen.theory.kaimal import iec_kaimal_params, iec_sigma1_m_s, kaimal_band_variance, kaimal_spectrum
from turbgen.theory.params import KaimalParams
from turbgen.theory.rotor_effective import rews_spectrum_kaimal


def test_kaimal_integrates_to_variance():
    total, _ = quad(lambda f: kaimal_spectrum(f, 2.0, 340.2, 16.0), 0, np.inf, limit=200)
    assert total == pytest.approx(4.0, rel=1e-6)
    band, _ = quad(lambda f: kaimal_spectrum(f, 2.0, 340.2, 16.0), 0.01, 0.1)
    assert kaimal_band_variance(0.01, 0.1, 2.0, 340.2, 16.0) == pytest.approx(band, rel=1e-8)
    assert kaimal_band_variance(0.0, np.inf, 2.0, 340.2, 16.0) == pytest.approx(4.0, rel=1e-12)


def test_iec_parameters_class_a_16():
    k = iec_kaimal_params(16.0, "A", 90.0)
    assert k.sigma_m_s[0] == pytest.approx(0.16 * (0.75 * 16 + 5.6))
    assert k.sigma_m_s[1] == pytest.approx(0.8 * k.sigma_m_s[0])
    assert k.sigma_m_s[2] == pytest.approx(0.5 * k.sigma_m_s[0])
    np.testing.assert_allclose(k.length_scales_m, (340.2, 113.4, 27.72))
    assert k.lc_m == pytest.approx(340.2)
    with pytest.raises(ParameterError):
        iec_sigma1_m_s(16.0, "D")


def test_coherence_models_square_to_paper_equations():
    f, r, U = np.array([0.01, 0.1, 0.5]), 28.28, 16.0
    eq12 = np.exp(-2 * 12.0 * r * np.sqrt((f / U) ** 2 + (0.12 / 340.2) ** 2))
    np.testing.assert_allclose(exponential_yz(r, f, U, 12.0, 340.2) ** 2, eq12, rtol=1e-12)
    eq18 = np.exp(-1.8 * 100.0 * np.sqrt((f / U) ** 2 + 1.49e-4**2))
    np.testing.assert_allclose(exponential_longitudinal(100.0, f, U, 1.8, 1.49e-4) ** 2, eq18, rtol=1e-12)
    a, b = simley_pao_parameters(3.0, 16.0, 340.2)
    assert a == pytest.approx(8.4 * 3 / 16 + 0.05) and b == pytest.approx(0.25 * 340.2**-1.24)
    assert np.all(kristensen(0.0, f, U, 3.0, 340.2) == 1.0)
    k = kristensen(100.0, f, U, 3.0, 340.2)
    assert np.all((k > 0) & (k < 1)) and np.all(np.diff(k) < 0)


def test_rews_kaimal_limits():
    kp = KaimalParams((2.0, 1.6, 1.0), (340.2, 113.4, 27.72), 12.0, 340.2)
    f = np.array([0.001, 0.01, 0.1, 1.0])
    s1 = kaimal_spectrum(f, 2.0, 340.2, 16.0)
    np.testing.assert_allclose(rews_spectrum_kaimal(f, kp, 16.0, [0.0], [0.0]), s1)
    # two points: S1 (1 + coh) / 2
    coh = exponential_yz(50.0, f, 16.0, 12.0, 340.2)
    np.testing.assert_allclose(rews_spectrum_kaimal(f, kp, 16.0, [0.0, 50.0], [0.0, 0.0]), s1 * (1 + coh) / 2)
    # full coherence (a_yz = 0) on any set of points gives S1
    kp0 = KaimalParams((2.0, 1.6, 1.0), (340.2, 113.4, 27.72), 0.0, 340.2)
    y, z = np.meshgrid(np.linspace(-60, 60, 5), np.linspace(-60, 60, 5))
    np.testing.assert_allclose(rews_spectrum_kaimal(f, kp0, 16.0, y, z), s1)
    with pytest.raises(ParameterError):
        rews_spectrum_kaimal(f, kp, 16.0, [0.0, 1.0], [0.0])
