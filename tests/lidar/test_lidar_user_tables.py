"""The lidar preview theory of Kaimal stores made with a user spectrum or yz coherence (the store's recorded tables).

Exactness arguments: a table given on the run's lines is the LineSpectrum's band means there (no interpolation), and
LineSpectrum.__call__ returns them exactly on a line; 2 x a table is exact in binary floating point and the preview
is linear in the spectra (every term S_c times a coherence sum), so the user preview of 2 x the IEC spectrum is 2 x
the IEC preview up to the round-off of evaluating the Kaimal spectrum on two arrays (rtol 1e-12). An all-ones yz
coherence equals the IEC exponential with a_yz = 0 (exp(0) = 1) exactly.
"""

from types import SimpleNamespace

import numpy as np

import turbgen
from turbgen.theory.kaimal import iec_kaimal_params, kaimal_spectrum
from turbgen.virtual_lidar.description import load_lidar
from turbgen.virtual_lidar.report import kaimal_store_preview

GRID = dict(U=16, nt=1024, ny=4, nz=4, planes=[0, 50], seed=1)  # the preview reads the tables only, not the field
IEC = iec_kaimal_params(16.0, "A", 150.0)
LIDAR = load_lidar("nacelle-4beam")
LINES = np.arange(8, 129, 16) / (1024 * 0.5)  # 8 of the record's lines up to 0.25 Hz (the preview costs ~1 s a line)


def _preview(**user):
    ds = turbgen.kaimal(**GRID, **user)
    return kaimal_store_preview(SimpleNamespace(attrs=dict(ds.attrs), U_m_s=16.0), LIDAR, LINES, 63.0)


def test_a_user_spectrum_of_twice_the_iec_one_doubles_the_preview():
    f = np.arange(1, 513) / (1024 * 0.5)  # every line of the run: the table is exact there
    S = [2.0 * kaimal_spectrum(f, s, L, 16.0) for s, L in zip(IEC.sigma_m_s, IEC.length_scales_m)]
    iec, user = _preview(), _preview(spectrum=(f, *S))
    for name in ("S_RR", "S_LL", "S_RL"):
        np.testing.assert_allclose(getattr(user, name), 2.0 * getattr(iec, name), rtol=1e-12, atol=0)
    np.testing.assert_allclose(user.coh2_RL, iec.coh2_RL, rtol=1e-12)
    # the preview's variance (S_LL summed over the lines) is twice the IEC one's
    assert abs(user.S_LL.sum() / iec.S_LL.sum() - 2.0) < 1e-12


def test_a_user_coherence_table_replaces_the_iec_one():
    ones = _preview(coherence=lambda f, r, U: np.ones(np.broadcast(f, r).shape), ayz=1.0)
    flat = _preview(ayz=0.0)  # the IEC exponential with a_yz = 0: coherence 1 everywhere
    for name in ("S_RR", "S_LL", "S_RL"):
        np.testing.assert_allclose(getattr(ones, name), getattr(flat, name), rtol=1e-12, atol=0)
    # the table, not the store's a_yz = 1, was used: IEC coherences < 1 lower the rotor average
    assert (ones.S_RR > 1.001 * _preview(ayz=1.0).S_RR).all()


def test_turbgen_lidar_runs_on_a_user_spectrum_store(tmp_path):
    def site(f_hz):  # twice the IEC spectra
        return 2.0 * np.stack([kaimal_spectrum(f_hz, s, L, 16.0) for s, L in zip(IEC.sigma_m_s, IEC.length_scales_m)])

    ds = turbgen.kaimal(U=16, nt=512, ny=14, nz=14, dy=10, dz=10, seed=2, spectrum=site)
    report = turbgen.lidar(ds)
    assert report.metric.checks and np.isfinite(report.coh2_theory).all(), report
