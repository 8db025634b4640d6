"""Lidar preview theory: independent limits, convergence, and the published cut-offs of Guo et al. (2023)."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.errors import ParameterError
from turbgen.virtual_lidar.description import PRESETS, LidarDescription, load_lidar
from turbgen.virtual_lidar.preview import preview_spectra
from turbgen.spec.preset_runs import mann_params_for
from turbgen.theory.kaimal import kaimal_spectrum
from turbgen.theory.lidar_geometry import Measurements, los_vectors, nacelle_directions, spinner_directions
from turbgen.theory.lidar_control import MINUS_3_DB, coherence_bandwidth_rad_m, cutoff_frequency_hz
from turbgen.theory.lidar_lattice import BoxLattice
from turbgen.theory.lidar_preview import kaimal_preview_spectra, mann_preview_spectra
from turbgen.theory.lidar_weighting import (
    cw_discrete, discrete_transform, gaussian_transform, lorentzian_transform, pulsed_discrete,
)
from turbgen.theory.mann_spectra import one_point_spectra
from turbgen.theory.params import KaimalParams, MannParams

U = 16.0


def _points(focus, n=(1.0, 0.0, 0.0)):
    """Point measurements (no probe volume) with LOS n at the given (x, y, z) focus points."""
    focus = np.atleast_2d(np.asarray(focus, dtype=float))
    m = focus.shape[0]
    n = np.tile(np.asarray(n, dtype=float), (m, 1))
    return Measurements(n=n, focus_m=focus, direction=n * [1, -1, -1], offsets_m=np.zeros((m, 1)),
                        weights=np.ones((m, 1)), beam=np.arange(m), gate=np.zeros(m, dtype=int))


def test_beam_geometry_frame():
    d = nacelle_directions([0.0, 30.0], [0.0, 0.0])
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    np.testing.assert_allclose(los_vectors(d)[0], [1.0, 0.0, 0.0])  # straight upstream: v_los = +u
    assert d[1, 1] > 0  # positive azimuth towards +y
    s = spinner_directions(20.0, [0.0, 90.0, 180.0, 270.0], tilt_deg=0.0)
    np.testing.assert_allclose(s[:, 0], np.cos(np.radians(20.0)))
    tilted = spinner_directions(0.0, [0.0], tilt_deg=6.0)[0]  # the shaft axis, tilted up
    np.testing.assert_allclose(tilted, [np.cos(np.radians(6)), 0.0, np.sin(np.radians(6))], atol=1e-15)


def test_table3_lidar_geometry():
    m = PRESETS["nacelle-4beam"].measurement_points()
    assert m.count == 40
    np.testing.assert_allclose(np.unique(m.focus_m[:, 0]), 50.0 + 13.3 * np.arange(10))
    np.testing.assert_allclose(m.weights.sum(axis=1), 1.0)
    # u_LL = mean(v_los / n_1) is u for a uniform u
    u_ll = np.mean((m.n @ np.array([7.0, 0.0, 0.0])) / m.n[:, 0])
    assert u_ll == pytest.approx(7.0)


def test_weights_match_their_continuous_transforms():
    s, w = pulsed_discrete(30.0)
    assert s.max() == pytest.approx(45.0) and s[1] - s[0] == pytest.approx(2.5)
    nu = np.linspace(0, 0.3, 31)
    # truncation at 3.5 sigma and the 2.5 m step change the Gaussian's transform by < 1e-3
    np.testing.assert_allclose(discrete_transform(nu, s, w), gaussian_transform(nu, 30.0), atol=1e-3)
    s, w = cw_discrete(20.0)
    assert s.max() == pytest.approx(120.0)
    # the truncated Lorentzian keeps ~90 % of the weight: at small nu its transform exceeds exp(-|nu| z_R)
    # by ~0.1 (why theory and virtual lidar both use the discrete weights), with a ripple beyond
    d = discrete_transform(nu[1:], s, w) - lorentzian_transform(nu[1:], 20.0)
    assert d[0] > 0.05 and np.abs(d).max() < 0.15


def test_point_beam_along_x_measures_u():
    """A vanishing probe volume on a beam along x at the rotor: S_LL = the one-point u spectrum."""
    p = mann_params_for("neutral", U)
    f = np.array([0.01, 0.05, 0.2])
    k1 = 2 * np.pi * f / U
    expected = 2.0 * one_point_spectra(k1, p)["F11"] * 2 * np.pi / U  # two-sided k1 -> one-sided f
    # a point has no probe volume to damp the inertial tail: integrate to kappa = 100 k1 (the default
    # kappa_max = 1 rad/m, ample for averaged lidar signals, drops ~2 % of F11 at 0.2 Hz)
    S = mann_preview_spectra(f, _points([[0.0, 0.0, 0.0]]), p, U, radius_m=0.05, kappa_max=8.0,
                             panel_width=0.2)
    np.testing.assert_allclose(S.S_LL, expected, rtol=2e-3)
    assert np.all(S.coh2_RL > 0.999)  # a 5 cm "rotor" at the same point


def test_rotor_disc_lidar_gives_full_coherence():
    """Points filling the rotor disc at x = 0, LOS along x: u_LL is the disc average, gamma^2 -> 1."""
    R = 63.0
    h = 4.5  # 613 points (min gamma^2 0.99956, max |G - 1| 0.003; at 3 m, 1373 points: 0.99979 and 0.006)
    c = np.arange(-R, R + h, h)
    yy, zz = np.meshgrid(c, c)
    inside = yy**2 + zz**2 <= R * R
    focus = np.stack([np.zeros(inside.sum()), yy[inside], zz[inside]], axis=1)
    f = np.array([0.01, 0.05, 0.1])
    S = mann_preview_spectra(f, _points(focus), mann_params_for("neutral", U), U, R)
    assert np.all(S.coh2_RL > 0.995)  # the grid of points is not the continuous disc (h / R = 0.07)
    np.testing.assert_allclose(S.G_RL, 1.0, atol=0.01)


def test_frozen_turbulence_keeps_coherence_and_evolution_lowers_it():
    lid = PRESETS["nacelle-1beam"]
    f = np.array([0.003, 0.008])  # below the single beam's k_0.5 (gamma^2 ~ 0.3 - 0.9)
    frozen = preview_spectra("mann", lid, U, f_hz=f, frozen=True)
    evolving = preview_spectra("mann", lid, U, f_hz=f)
    assert np.all(evolving.coh2_RL < frozen.coh2_RL)


def test_isotropy_at_gamma_zero():
    """At Gamma = 0 the tensor is isotropic: a beam tilted in azimuth and one tilted in elevation by the
    same angle (the same point rotated by 90 deg about x) have the same S_LL; with shear they differ."""
    d = nacelle_directions([20.0, 0.0], [0.0, 20.0])
    n = los_vectors(d)
    f = np.array([0.02, 0.1])
    for gamma, same in ((0.0, True), (3.9, False)):
        p = MannParams(0.1, 49.0, gamma, evo_time_s=None)
        a = mann_preview_spectra(f, _points([50 * d[0]], n[0]), p, U, 63.0).S_LL
        b = mann_preview_spectra(f, _points([50 * d[1]], n[1]), p, U, 63.0).S_LL
        assert np.allclose(a, b, rtol=1e-4) is same


def test_kaimal_point_limits():
    kp = KaimalParams((2.0, 1.6, 1.0), (340.2, 113.4, 27.7))
    f = np.array([0.01, 0.1])
    meas = _points([[1.0, 0.0, 0.0]])
    S = kaimal_preview_spectra(f, meas, kp, U, 1.0, lambda dx, ff: np.ones_like(dx * ff), rotor_spacing_m=2.0)
    np.testing.assert_allclose(S.S_LL, kaimal_spectrum(f, 2.0, 340.2, U), rtol=1e-12)
    assert np.all(S.coh2_RL > 0.9999)


def test_quadrature_converged():
    """gamma^2 and |G| on the default nodes agree with twice-refined nodes to 1e-3 (target 0.005)."""
    meas = PRESETS["nacelle-4beam"].measurement_points()
    p = mann_params_for("neutral", U)
    f = np.array([0.01, 0.05, 0.1])
    a = mann_preview_spectra(f, meas, p, U, 63.0)
    b = mann_preview_spectra(f, meas, p, U, 63.0, kappa_max=2.0, n_theta=320, panel_width=0.025)
    np.testing.assert_allclose(a.coh2_RL, b.coh2_RL, atol=1e-3)
    np.testing.assert_allclose(a.G_RL, b.G_RL, atol=1e-3)


# Guo et al. (2023) Table 5: -3 dB cut-off of |G_RL| at 16 m/s, Table 3 lidar, NREL 5 MW [Hz]
TABLE5 = {
    ("mann", "unstable"): 0.0544, ("mann", "neutral"): 0.0490, ("mann", "stable"): 0.0455,
    ("kaimal", "unstable"): 0.0347, ("kaimal", "neutral"): 0.0449, ("kaimal", "stable"): 0.0439,
}


@pytest.mark.parametrize("model,preset", sorted(TABLE5))
def test_table5_cutoffs(model, preset):
    f = np.geomspace(0.025, 0.08, 14)
    S = preview_spectra(model, PRESETS["nacelle-4beam"], U, preset=preset, f_hz=f)
    fc = cutoff_frequency_hz(f, S.G_RL)
    assert fc == pytest.approx(TABLE5[(model, preset)], rel=0.10)


def test_single_nacelle_beam_bandwidth_fu2023():
    """Fu et al. (2023): a nacelle single beam reaches k_0.5 ~ 0.005 rad/m (IEA 15 MW, 18 m/s)."""
    p = MannParams(0.2882, 49.0, 3.1)
    f = np.geomspace(0.003, 0.1, 40)
    S = preview_spectra("mann", PRESETS["nacelle-1beam"], 18.0, f_hz=f, mann=p)
    k05 = coherence_bandwidth_rad_m(f, S.coh2_RL, 18.0)
    assert 0.003 < k05 < 0.008


def test_bad_lidars_are_refused(tmp_path):
    with pytest.raises(ParameterError, match="FWHM|fwhm"):
        LidarDescription("x", "pulsed", "nacelle", (50.0,), 1.0, 63.0, (0.0,), (0.0,), fwhm_m=0.0)
    with pytest.raises(ParameterError, match="neither a preset"):
        load_lidar("no-such-lidar")
    with pytest.raises(ParameterError, match="lidar file nothere.toml: does not exist"):  # not "neither a ..."
        load_lidar("nothere.toml")
    (tmp_path / "d.toml").mkdir()
    with pytest.raises(ParameterError, match=r"not a regular file \(a directory\)"):
        load_lidar(tmp_path / "d.toml")
    bad = tmp_path / "l.json"
    bad.write_text(json.dumps({"kind": "pulsed", "mount": "nacelle", "ranges_m": [50], "beam_rate_hz": 1,
                               "rotor_radius_m": 63, "azimuth_deg": [95], "elevation_deg": [0]}))
    with pytest.raises(ParameterError, match="azimuth"):
        load_lidar(bad)
    good = tmp_path / "l.toml"
    good.write_text('kind = "cw"\nmount = "spinner"\nranges_m = [150]\nbeam_rate_hz = 4\nrotor_radius_m = 120\n'
                    'half_cone_deg = 20\nscan_deg = [0, 90, 180, 270]\n')
    assert load_lidar(good).n_beams == 4


def test_cli_theory_lidar_json_keys_and_errors():
    from turbgen.cli import cli

    r = CliRunner().invoke(cli, ["theory", "lidar", "--f", "0.02,0.05,0.08", "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    for key in ("f", "coh2_RL", "G_RL", "k05_rad_m", "cutoff_hz"):
        assert key in out
    assert len(out["coh2_RL"]) == 3 and 0.04 < out["cutoff_hz"] < 0.06
    r = CliRunner().invoke(cli, ["theory", "lidar", "--lidar", "nope"])
    assert r.exit_code == 2 and "neither a preset" in r.output


@pytest.mark.slow
def test_fu2023_spinner_optima():
    """Fu et al. (2023) at their optima (U = 18 m/s, ae 0.2882, L 49 m, Gamma 3.1, gamma 400 s): both
    spinner lidars reach k_0.5 ~ 0.014 rad/m; buffer times 0.7 s (CW) and 1.62 s (pulsed) with
    T_pitch = 0.9 s and f_delay = 0.025 Hz. Ours: 0.0139 / 0.0144 rad/m, 0.67 / 1.63 s."""
    from turbgen.virtual_lidar.optimize import evaluate

    p = MannParams(0.2882, 49.0, 3.1, evo_time_s=400.0)
    cw = evaluate(PRESETS["spinner-cw"], p, 18.0)
    pulsed = evaluate(PRESETS["spinner-pulsed"], p, 18.0)
    assert cw.k05_rad_m == pytest.approx(0.014, rel=0.05)
    assert pulsed.k05_rad_m == pytest.approx(0.014, rel=0.05) and pulsed.k05_rad_m > 0.014
    assert cw.buffer_time_s == pytest.approx(0.7, abs=0.15)
    assert pulsed.buffer_time_s == pytest.approx(1.62, abs=0.15)


def test_optimize_command_small_grid():
    from turbgen.cli.lidar_optimize import optimize

    r = CliRunner().invoke(optimize, ["--lidar", "spinner-pulsed", "--ranges", "220", "--cones", "12,18",
                                      "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    assert len(out["candidates"]) == 2
    assert out["optimum"]["half_cone_deg"] == 18.0  # the wider cone previews better at 220 m
    r = CliRunner().invoke(optimize, ["--lidar", "nacelle-4beam", "--ranges", "100", "--cones", "10"])
    assert r.exit_code != 0 and "spinner" in str(r.exception or r.output)


def test_lidar_ti_correction_limits():
    """Schlipf et al. (2020) Eq. 6-8: a point beam along x sampled as fast as the field has c_TI = 1;
    a probe volume and tilted beams lose variance (c_TI > 1), more for a longer probe volume."""
    from turbgen.theory.kaimal import iec_kaimal_params
    from turbgen.theory.lidar_los import lidar_ti_correction

    kp = iec_kaimal_params(16.0, "A", 90.0)
    c = lidar_ti_correction(_points([[50.0, 0.0, 0.0]]), kp, U, f_scan_hz=1.0, f_max_hz=1.0, n_f=400)
    assert c[0] == pytest.approx(1.0, abs=2e-3)  # trapezoid in ln f on 400 nodes
    meas = PRESETS["nacelle-4beam"].measurement_points().subset([0])
    wide = LidarDescription("w", "pulsed", "nacelle", (50.0,), 4.0, 63.0, (14.4,), (14.0,), fwhm_m=60.0)
    c30 = lidar_ti_correction(meas, kp, U)[0]
    c60 = lidar_ti_correction(wide.measurement_points(), kp, U)[0]
    assert 1.0 < c30 < c60


def test_box_lattice_converges_to_the_continuous_integral():
    """The sum over a periodic box's (k2, k3) lattice tends to the polar quadrature as the box grows.

    The box of a 32 x 32 store of 4.7 m padded twice (64 x 64) lowers gamma^2_RL at 1/64 Hz by ~0.005: the
    lateral wavenumbers below 2 pi / 300 m that it cannot hold shape the lowest bins; 4 and 8 times wider
    boxes converge to the continuous value within the polar quadrature's own accuracy (1e-3, above)."""
    meas = PRESETS["nacelle-4beam"].measurement_points()
    p = mann_params_for("neutral", U)
    f = np.array([1.0, 2.0, 4.0]) / 64
    cont = mann_preview_spectra(f, meas, p, U, 63.0).coh2_RL
    err = [np.abs(mann_preview_spectra(f, meas, p, U, 63.0, box=BoxLattice(n, n, 4.7, 4.7, 512.0)).coh2_RL - cont)
           for n in (64, 128, 256)]
    assert err[0][0] > 3e-3
    assert np.all(err[1] < err[0]) and np.all(err[2] < err[1]) and err[2].max() < 1e-3


def test_crossings_do_not_depend_on_the_frequency_grid():
    """The -3 dB / 0.5 crossings of a smooth curve: exact for a cubic in log f, and on a smooth gain-like
    curve the same to < 5e-5 relative on grids of 12, 14 and 60 points (linear interpolation in log f, used
    before, moved the cut-off's 4th digit with the grid: 0.05064 / 0.05080 / 0.05078 Hz for one lidar)."""
    f = np.geomspace(0.01, 0.2, 9)
    cubic = lambda x: 1.0 - 0.1 * (x + 4.6) - 0.05 * (x + 4.6) ** 3  # noqa: E731 -- in x = ln f, decreasing
    fine = np.geomspace(0.01, 0.2, 200001)
    exact = fine[np.argmax(cubic(np.log(fine)) < 0.5)]
    assert cutoff_frequency_hz(f, cubic(np.log(f)) * MINUS_3_DB / 0.5) == pytest.approx(exact, rel=1e-4)
    gain = lambda f_hz: 1.0 / np.sqrt(1.0 + (f_hz / 0.05) ** 2.4)  # noqa: E731 -- crosses 10^(-3/20) at 0.05 Hz
    want = 0.05 * (MINUS_3_DB**-2 - 1.0) ** (1 / 2.4)
    # relative errors 2.5e-5, 5e-6, 6e-6 here (linear interpolation: 1.1e-3, 5e-4, 6e-4, over 4th-digit rounding)
    for grid in (np.geomspace(0.02, 0.1, 12), np.geomspace(0.025, 0.08, 14), np.geomspace(0.002, 0.5, 60)):
        assert cutoff_frequency_hz(grid, gain(grid)) == pytest.approx(want, rel=5e-5), grid.size
    three = np.array([0.01, 0.05, 0.1])  # fewer than 4 points: linear in log f
    y = np.array([1.0, 0.8, 0.6])
    assert coherence_bandwidth_rad_m(three, y**2, 10.0) == pytest.approx(
        2 * np.pi * np.exp(np.interp(0.5, [0.6**2, 0.8**2], np.log([0.1, 0.05]))) / 10.0, rel=1e-12)
    assert cutoff_frequency_hz(f, np.full(9, 0.1)) == f[0] and np.isnan(cutoff_frequency_hz(f, np.ones(9)))
