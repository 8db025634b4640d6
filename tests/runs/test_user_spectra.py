"""User spectra of the Kaimal generator (``turbgen.kaimal(spectrum=...)``, ``turbgen kaimal --spectrum``).

Exactness arguments used below:

* 4 S gives exactly 2 x the field of S: the band means of 4 S are 4 x those of S (a power of two scales every
  product and sum exactly in binary floating point), sqrt(4 v) = 2 sqrt(v) exactly (sqrt is correctly rounded), and
  the inverse FFT of twice the coefficients is twice the transform, operation by operation. Tolerance: none.
* The IEC Kaimal spectrum given as a callable: its band means by 16-point Gauss-Legendre quadrature agree with the
  closed-form band integrals to ~1e-15 relative (checked); the float32 amplitudes sqrt(v)/2 then round to the same
  float32 unless a value lies within 1e-15 of a rounding boundary (probability ~1e-15 / 2^-24 ~ 2e-8 per line), so
  the fields are compared bit for bit; the float64 variances to rtol 1e-13 (100 x the quadrature's error).
"""

import re

import numpy as np
import pytest
from click.testing import CliRunner

import turbgen
from turbgen.cli import cli as main
from turbgen.errors import ParameterError
from turbgen.runs.kaimal import kaimal_generator
from turbgen.spec.kaimal import KaimalRun
from turbgen.store import open_store
from turbgen.theory.kaimal import iec_kaimal_params, kaimal_band_variance, kaimal_spectrum
from turbgen.theory.lattice import line_bands
from turbgen.theory.user_spectra import LineSpectrum
from turbgen.validation import validate

from relabelled_store import without_parameter

SMALL = dict(U=12, nt=128, ny=6, nz=6, planes=[0, 50, 100], seed=2)
IEC = iec_kaimal_params(12.0)


def iec_density(f_hz):
    """The IEC Kaimal PSDs of u, v, w at U = 12 m/s, class A (Guo et al. 2023, Eq. 11)."""
    return np.stack([kaimal_spectrum(f_hz, s, L, 12.0) for s, L in zip(IEC.sigma_m_s, IEC.length_scales_m)])


def site_density(f_hz):
    """A spectrum unlike the IEC one: Kaimal shapes with other sigmas and lengths and a bump at 0.2 Hz (u)."""
    S = np.stack([kaimal_spectrum(f_hz, s, L, 12.0) for s, L in [(2.0, 120.0), (1.5, 60.0), (1.0, 15.0)]])
    S[0] += 0.5 * np.exp(-(((f_hz - 0.2) / 0.03) ** 2))
    return S


def _fields(ds):
    return [ds[c].values for c in "uvw"]


def test_four_times_the_spectrum_is_exactly_twice_the_field():
    a = turbgen.kaimal(**SMALL, spectrum=site_density)
    b = turbgen.kaimal(**SMALL, spectrum=lambda f: 4.0 * site_density(f))
    for x, y in zip(_fields(a), _fields(b)):
        np.testing.assert_array_equal(y, 2.0 * x)
        assert np.abs(x).max() > 0


def test_the_iec_spectrum_as_a_callable_gives_the_default_field():
    run = KaimalRun.from_mapping({"U_m_s": 12.0, "grid": {"nt": 128, "ny": 6, "nz": 6, "x_m": [0, 50, 100]}})
    user = LineSpectrum.from_callable(iec_density, 128, run.grid.dt_s)
    default = kaimal_generator(run).variances
    for i, c in enumerate("uvw"):
        np.testing.assert_allclose(user.line_variances()[i], default[c], rtol=1e-13, atol=0)
    for x, y in zip(_fields(turbgen.kaimal(**SMALL)), _fields(turbgen.kaimal(**SMALL, spectrum=iec_density))):
        np.testing.assert_array_equal(x, y)


def test_the_iec_spectrum_as_a_table_of_band_means_gives_the_default_field():
    nt, dt = 128, 0.5
    lo, hi = line_bands(nt, dt)
    means = [kaimal_band_variance(lo[1:], hi[1:], s, L, 12.0) / (hi - lo)[1:]
             for s, L in zip(IEC.sigma_m_s, IEC.length_scales_m)]  # fmt: skip
    table = {"f_hz": np.arange(1, nt // 2 + 1) / (nt * dt), "S_u": means[0], "S_v": means[1], "S_w": means[2]}
    default = turbgen.kaimal(**SMALL)
    for x, y in zip(_fields(default), _fields(turbgen.kaimal(**SMALL, spectrum=table))):
        # v = S (hi - lo) after S = v / (hi - lo): float64 round-off (<= 2 ulp), below the float32 amplitudes' ulp
        np.testing.assert_allclose(y, x, rtol=0, atol=4 * np.finfo(np.float32).eps * np.abs(x).max())


def test_a_rerun_from_the_store_s_table_is_the_same_field(tmp_path):
    out = tmp_path / "site.zarr"
    original = turbgen.kaimal(**SMALL, spectrum=site_density, out=out)
    recorded = open_store(out).attrs["parameters"]["spectrum"]
    assert set(recorded) == {"f_hz", "S_u", "S_v", "S_w"} and len(recorded["f_hz"]) == 64
    again = turbgen.kaimal(**SMALL, spectrum=recorded)
    rerun = KaimalRun.from_attrs(open_store(out).attrs)
    assert rerun.spectrum == KaimalRun.from_attrs(dict(again.attrs)).spectrum
    for x, y in zip(_fields(original), _fields(again)):
        np.testing.assert_array_equal(x, y)


def test_the_recorded_sigmas_are_the_spectrum_s_and_an_explicit_sigma_is_refused(site_store):
    ds = turbgen.kaimal(**SMALL, spectrum=site_density, long_model="simley-pao")
    run = KaimalRun.from_attrs(dict(ds.attrs))
    # the spectrum's sigma as the generator realises it: its line variances summed (not the IEC class's 2.5 m/s)
    sigma = np.sqrt(run.spectrum.line_variances().sum(axis=1))
    for shown in (turbgen.info(ds)["parameters"]["sigma_m_s"], ds.attrs["derived"]["expected_sigma_m_s"]):
        np.testing.assert_array_equal(shown, sigma)
    assert run.sigma_total_m_s == np.sqrt(np.sum(sigma**2)) and not np.allclose(sigma, IEC.sigma_m_s, rtol=0.1)
    # the command's summary shows them too; --sigma with --spectrum: one line, exit 2, nothing written
    info = CliRunner().invoke(main, ["info", str(site_store)]).output
    recorded = open_store(site_store).attrs["parameters"]["sigma_m_s"]
    assert re.search(r"sigma_m_s +" + ", ".join(f"{s:g}" for s in recorded), info), info
    r = CliRunner().invoke(main, ["kaimal", "--spectrum", "x.csv", "--sigma", "1,1,1", "--out", "never.zarr"])
    assert r.exit_code == 2 and "scale the spectrum instead" in r.output and r.output.count("\n") == 1, r.output


def _write_csv(path, f_hz, S, digits=8):
    rows = "\n".join(",".join(f"{v:.{digits}g}" for v in row) for row in np.column_stack([f_hz, *S]))
    path.write_text("# site spectra\nf_hz,S_u,S_v,S_w\n" + rows + "\n")
    return path


@pytest.fixture(scope="module")
def site_store(tmp_path_factory):
    """A 2048 x 3 x 16 x 16 field (the validator's small test grid) of a site table given as CSV, by the command."""
    tmp = tmp_path_factory.mktemp("site")
    f = np.geomspace(1e-4, 2.0, 60)
    csv = _write_csv(tmp / "site.csv", f, site_density(f))
    out = tmp / "site.zarr"
    r = CliRunner().invoke(main, ["kaimal", "--spectrum", str(csv), "--nt", "2048", "--ny", "16", "--nz", "16",
                                  "--dy", "8", "--planes", "0,20,60", "--U", "12", "--seed", "3", "--out", str(out)])
    assert r.exit_code == 0, r.output
    return out


def test_validate_passes_against_the_recorded_table_and_fails_against_kaimal(site_store, tmp_path):
    report = validate(site_store, rotor_radius_m=40.0)
    assert report.passed, report.table()
    # the same field declared a default Kaimal field (the store's attributes without the table) fails its spectra
    plain = without_parameter(site_store, "spectrum", tmp_path / "plain.zarr")
    failed = {m.name for m in validate(plain, rotor_radius_m=40.0).metrics if not m.passed}
    assert {"spectrum_u", "spectrum_v", "spectrum_w"} <= failed


BAD_TABLES = {
    "negative": (lambda f, S: (f, S * np.array([[1.0], [-1.0], [1.0]])), "S_v = -"),
    "not finite": (lambda f, S: (f, np.where(np.arange(f.size) == 5, np.nan, S)), "S_u = nan"),
    "not increasing": (lambda f, S: (f[::-1], S[:, ::-1]), "must increase"),
    "short of the lines": (lambda f, S: (f[f < 0.5], S[:, f < 0.5]), "the run's lines need"),
    "wrong shape": (lambda f, S: (f, S[:2]), r"needs n frequencies and \(3, n\)"),
}


@pytest.mark.parametrize("name", BAD_TABLES)
def test_a_bad_table_is_refused_in_one_line(name, tmp_path):
    change, message = BAD_TABLES[name]
    f = np.geomspace(1e-3, 2.0, 30)
    bad_f, bad_S = change(f, site_density(f))
    with pytest.raises(ParameterError, match=message) as err:
        turbgen.kaimal(**SMALL, spectrum=(bad_f, *bad_S))
    assert "\n" not in str(err.value)
    if name == "wrong shape":
        return
    csv = _write_csv(tmp_path / "bad.csv", bad_f, bad_S)
    out = tmp_path / "never.zarr"
    r = CliRunner().invoke(main, ["kaimal", "--spectrum", str(csv), "--nt", "128", "--ny", "4", "--nz", "4",
                                  "--out", str(out)])
    assert r.exit_code == 2 and r.output.count("\n") == 1 and re.search(message, r.output), r.output
    assert "Traceback" not in r.output and not out.exists()


def test_a_callable_of_the_wrong_shape_and_rescale_are_refused():
    with pytest.raises(ParameterError, match=r"returned shape \(2, .*needs \(3, "):
        turbgen.kaimal(**SMALL, spectrum=lambda f: site_density(f)[:2])
    with pytest.raises(ParameterError, match="rescale"):
        turbgen.kaimal(**SMALL, spectrum=site_density, rescale=True)
    with pytest.raises(ParameterError, match="first line must name the columns"):
        turbgen.kaimal(**SMALL, spectrum=__file__)


def test_a_sweep_with_a_spectrum_file_makes_the_field_of_the_command(tmp_path):
    from turbgen.runs.models import get_model
    from turbgen.sweep.plan_file import plan_from_mapping

    f = np.geomspace(1e-3, 2.0, 40)
    _write_csv(tmp_path / "site.csv", f, site_density(f))
    plan = plan_from_mapping({"out": "sweep", "models": ["kaimal", "mann"], "presets": ["neutral"], "speeds": [12],
                              "seeds": [5], "spectrum": "site.csv", "grid": {"nt": 128, "ny": 4, "nz": 4, "dy": 8},
                              "kaimal": {"planes": [0, 50]}, "mann": {"planes": [0, 50]}},
                             base_dir=tmp_path)  # fmt: skip
    by_model = {r.model: r.run for r in plan.runs}
    assert by_model["mann"].model == "mann" and plan.to_dict()["spectrum"] == str(tmp_path / "site.csv")
    get_model("kaimal").run(by_model["kaimal"], tmp_path / "swept.zarr")
    single = turbgen.kaimal(preset="neutral", U=12, seed=5, nt=128, ny=4, nz=4, dy=8, planes=[0, 50],
                            spectrum=tmp_path / "site.csv")
    swept = open_store(tmp_path / "swept.zarr")
    assert swept.attrs["parameters"]["spectrum"] == single.attrs["parameters"]["spectrum"]
    for c in "uvw":
        np.testing.assert_array_equal(swept.read_plane(c, 1), single[c].values[:, 1])
