"""Grid, CLI list parsers, Kaimal closed forms and coherence models."""

import click
import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import quad

from turbgen import __version__
from turbgen.cli import cli
from turbgen.cli.options import parse_floats, parse_ints, parse_range
from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.theory import coherence_models as cm
from turbgen.theory.kaimal import iec_kaimal_params, iec_lambda1_m, kaimal_band_variance, kaimal_spectrum


def test_grid_coordinates():
    g = Grid(nt=8, dt_s=0.5, x_m=(0.0, 50.0), ny=4, nz=3, dy_m=2.0, dz_m=5.0)
    assert g.shape == (8, 2, 4, 3)
    np.testing.assert_allclose(g.y(), [-3, -1, 1, 3])
    np.testing.assert_allclose(g.z(), [-5, 0, 5])
    assert g.t()[-1] == 3.5 and g.nbytes_per_component() == 8 * 2 * 4 * 3 * 4


@pytest.mark.parametrize("bad", [dict(nt=1), dict(dt_s=0), dict(x_m=()), dict(x_m=(0, 0)), dict(dy_m=float("nan"))])
def test_grid_rejects_bad_values(bad):
    kw = dict(nt=8, dt_s=0.5, x_m=(0.0,), ny=4, nz=3, dy_m=2.0, dz_m=5.0) | bad
    with pytest.raises(ParameterError):
        Grid(**kw)


def test_option_parsers():
    assert parse_floats("0, 50,100", "--planes") == [0.0, 50.0, 100.0]
    gates = parse_range("50:170:13.3", "--gates")
    assert len(gates) == 10 and gates[0] == 50 and gates[-1] == pytest.approx(169.7)
    assert parse_ints("1-3,7", "--seeds") == [1, 2, 3, 7]
    for fn, text in [(parse_floats, "a,b"), (parse_range, "5:1:1"), (parse_ints, "3-1")]:
        with pytest.raises(click.BadParameter):
            fn(text, "--x")


def test_kaimal_integrates_to_sigma_squared():
    s = kaimal_spectrum
    total, _ = quad(lambda lf: s(np.exp(lf), 2.0, 340.2, 16.0) * np.exp(lf), -30, 80, limit=800, epsrel=1e-10)
    assert total == pytest.approx(4.0, rel=1e-6)
    assert kaimal_band_variance(0, np.inf, 2.0, 340.2, 16.0) == pytest.approx(4.0, rel=1e-12)
    band, _ = quad(lambda f: s(f, 2.0, 340.2, 16.0), 0.01, 1.0)
    assert kaimal_band_variance(0.01, 1.0, 2.0, 340.2, 16.0) == pytest.approx(band, rel=1e-8)


def test_iec_parameters():
    p = iec_kaimal_params(16.0, "A", 90.0)
    # sigma1 = 0.16 (0.75*16 + 5.6) = 2.816; L = (8.1, 2.7, 0.66) * 42 (Table 1 neutral row: 340.2, 113.4, 27.72)
    np.testing.assert_allclose(p.sigma_m_s, (2.816, 2.2528, 1.408))
    np.testing.assert_allclose(p.length_scales_m, (340.2, 113.4, 27.72))
    assert p.lc_m == pytest.approx(340.2) and p.a_yz == 12.0
    assert iec_lambda1_m(50.0) == pytest.approx(35.0)
    with pytest.raises(ParameterError):
        iec_kaimal_params(16.0, "D", 90.0)


def test_coherence_models():
    f = np.array([0.0, 0.05, 0.2])
    # Eq. 12 squared form = exp(-2 a r sqrt(...)): the un-squared function squared
    sq = np.exp(-2 * 12 * 20 * np.sqrt((f / 16) ** 2 + (0.12 / 340.2) ** 2))
    np.testing.assert_allclose(cm.exponential_yz(20, f, 16.0, 12.0, 340.2) ** 2, sq, rtol=1e-12)
    # Eq. 18 squared
    sq_x = np.exp(-1.8 * 100 * np.sqrt((f / 16) ** 2 + 1.49e-4**2))
    np.testing.assert_allclose(cm.exponential_longitudinal(100, f, 16, 1.8, 1.49e-4) ** 2, sq_x, rtol=1e-12)
    a, b = cm.simley_pao_parameters(3.0, 15.0, 340.2)
    assert a == pytest.approx(8.4 * 0.2 + 0.05) and b == pytest.approx(0.25 * 340.2**-1.24)
    k = cm.kristensen(np.array([0.0, 50.0, 200.0]), 0.05, 16.0, 3.5, 340.2)
    assert k[0] == 1.0 and 1.0 > k[1] > k[2] > 0.0
    # Kristensen decreases with frequency at fixed separation
    kf = cm.kristensen(100.0, np.array([0.01, 0.05, 0.2]), 16.0, 3.5, 340.2)
    assert np.all(np.diff(kf) < 0)


def test_cli_version_and_help():
    r = CliRunner().invoke(cli, ["--version"])
    assert r.exit_code == 0 and __version__ in r.output
    assert CliRunner().invoke(cli, ["--help"]).exit_code == 0


def test_cli_imports_commands_lazily():
    # `turbgen info` must not pay for the FFT / synthesis stack (start-up 0.5 s instead of ~2 s)
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from click.testing import CliRunner\n"
        "from turbgen.cli import cli\n"
        "r = CliRunner().invoke(cli, ['info', '--help'])\n"
        "assert r.exit_code == 0, r.output\n"
        "print(sorted(m for m in ('pyfftw', 'turbgen.synthesis', 'turbgen.validation', 'dask.distributed') "
        "if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    # every listed command resolves
    from turbgen.cli import COMMANDS

    for name in COMMANDS:
        assert cli.get_command(None, name).name == name
