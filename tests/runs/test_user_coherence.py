"""User yz coherence of the Kaimal generator (``turbgen.kaimal(coherence=...)``, ``KaimalGenerator(coherence=...)``).

The IEC coherence given as a callable does not give the default field's bits: the default sampler evaluates the
closed-form coherence on circulant tori reaching far beyond the grid (decay-length rule, turbgen.synthesis.circulant),
where a user coherence is known only at the grid's separations (the table a store can hold). Both samplers realise
the same covariance on the grid, which is checked exactly below: the realised yz correlation of every bin
(turbgen.synthesis.kaimal_conditioning.BinPrior, from the float32 values the generator samples with) against the
closed form, to 1e-6 (float32 scales: ~1e-7 relative per eigenvalue, summed over the torus).
"""

import numpy as np
import pytest

import turbgen
from turbgen.errors import ParameterError
from turbgen.runs.kaimal import kaimal_generator
from turbgen.spec.kaimal import KaimalRun
from turbgen.store import open_store
from turbgen.synthesis.kaimal_conditioning import component_prior
from turbgen.theory.coherence_models import exponential_yz
from turbgen.theory.kaimal import iec_kaimal_params
from turbgen.validation import validate

from relabelled_store import without_parameter

SMALL = dict(U=12, nt=128, ny=6, nz=6, dy=5, planes=[0, 50, 100], seed=2)
IEC = iec_kaimal_params(12.0)


def iec_coherence(f_hz, r_m, U_m_s):
    """The IEC exponential coherence (Guo et al. 2023, Eq. 12, un-squared) of class A at the default a_yz, Lc."""
    return exponential_yz(r_m, f_hz, U_m_s, IEC.a_yz, IEC.lc_m)


def site_coherence(f_hz, r_m, U_m_s):
    """A coherence clearly unlike the IEC one: a third of its decay (a_yz = 4) and a larger Lc."""
    return exponential_yz(r_m, f_hz, U_m_s, 4.0, 800.0)


def _realised_error(ds) -> float:
    """max |R_k(a, b) - IEC(r_ab, f_k)| over the grid's point pairs and the bins of u, as the generator samples."""
    run = KaimalRun.from_attrs(dict(ds.attrs))
    g = run.grid
    iy, iz = np.divmod(np.arange(g.ny * g.nz), g.nz)
    r = np.hypot((iy[:, None] - iy[None, :]) * g.dy_m, (iz[:, None] - iz[None, :]) * g.dz_m)
    gen = kaimal_generator(run)
    return max(float(np.abs(b.at_points(iy, iz, g.nz) - iec_coherence(gen.freqs[b.k], r, run.U_m_s)).max())
               for b in component_prior(gen, "u"))  # fmt: skip


def test_the_iec_coherence_as_a_callable_is_the_default_covariance_on_the_grid():
    user, default = turbgen.kaimal(**SMALL, coherence=iec_coherence), turbgen.kaimal(**SMALL)
    assert _realised_error(user) < 1e-6 and _realised_error(default) < 1e-6
    assert "coherence" not in default.attrs["parameters"]
    recorded = user.attrs["parameters"]["coherence"]
    assert len(recorded["f_hz"]) == 64 and recorded["r_m"][0] == 0 and len(recorded["r_m"]) == 20  # 6 x 6 at 5 m


def test_a_rerun_from_the_store_s_table_and_the_generator_give_the_same_field(tmp_path):
    original = turbgen.kaimal(**SMALL, coherence=site_coherence, vw_coherence="exp", out=tmp_path / "site.zarr")
    recorded = open_store(tmp_path / "site.zarr").attrs["parameters"]["coherence"]
    again = turbgen.kaimal(**SMALL, coherence=recorded, vw_coherence="exp")
    run = KaimalRun.from_attrs(dict(again.attrs))
    generated = turbgen.KaimalGenerator(run.kaimal, run.grid, 12.0, hub_height_m=run.hub_height_m,
                                        vw_coherence="exp", coherence=site_coherence).field(seed=2)  # fmt: skip
    for c in "uvw":
        np.testing.assert_array_equal(original[c].values, again[c].values)
        np.testing.assert_array_equal(original[c].values, generated[c].values)


@pytest.fixture(scope="module")
def site_store(tmp_path_factory):
    """A 2048 x 3 x 16 x 16 field (the validator's small test grid) of the site coherence."""
    out = tmp_path_factory.mktemp("coh") / "site.zarr"
    turbgen.kaimal(U=12, seed=3, nt=2048, ny=16, nz=16, dy=8, planes=[0, 20, 60], coherence=site_coherence, out=out)
    return out


def test_validate_passes_against_the_stored_coherence_and_fails_against_the_iec_one(site_store, tmp_path):
    report = validate(site_store, rotor_radius_m=40.0)
    assert report.passed, report.table()
    # the same field declared an IEC-coherence field (the store's attributes without the table) fails its coherence
    plain = without_parameter(site_store, "coherence", tmp_path / "plain.zarr")
    failed = {m.name for m in validate(plain, rotor_radius_m=40.0).metrics if not m.passed}
    assert "yz_coherence_u" in failed and not {"spectrum_u", "yz_coherence_v"} & failed


BAD = {
    "not 1 at r = 0": (lambda f, r, U: 0.9 * iec_coherence(f, r, U), "1 at r = 0"),
    "above 1": (lambda f, r, U: 1.5 + 0 * r * f, "in \\[-1, 1\\]"),
    "wrong shape": (lambda f, r, U: np.ones(3), "did not return"),
}


@pytest.mark.parametrize("name", BAD)
def test_a_bad_coherence_is_refused_in_one_line(name):
    coh, message = BAD[name]
    with pytest.raises(ParameterError, match=message) as err:
        turbgen.kaimal(**SMALL, coherence=coh)
    assert "\n" not in str(err.value)


def test_the_command_s_coherence_file_is_the_api_s_table(tmp_path):
    from click.testing import CliRunner

    from turbgen.cli import cli

    ds = turbgen.kaimal(**SMALL, coherence=site_coherence)
    table = ds.attrs["parameters"]["coherence"]
    rows = [f"{r!r},{c!r},{f!r}" for f, row in zip(table["f_hz"], table["coh"]) for r, c in zip(table["r_m"], row)]
    csv = tmp_path / "coh.csv"  # the columns and rows in any order; repr: the table's float64 values exactly
    csv.write_text("# lines x separations\nr_m,coh,f_hz\n" + "\n".join(rows[::-1]) + "\n")
    out = tmp_path / "cli.zarr"
    args = ["kaimal", "--U", "12", "--nt", "128", "--ny", "6", "--nz", "6", "--dy", "5", "--planes", "0,50,100",
            "--seed", "2", "--coherence", str(csv)]
    r = CliRunner().invoke(cli, [*args, "--out", str(out)])
    assert r.exit_code == 0 and "yz coherence" in r.output, r.output
    fs = open_store(out)
    assert fs.attrs["parameters"]["coherence"] == table
    for c in "uvw":
        np.testing.assert_array_equal(fs.read_plane(c, 1), ds[c].values[:, 1])
    np.testing.assert_array_equal(turbgen.kaimal(**SMALL, coherence=csv).u.values, ds.u.values)
    csv.write_text(csv.read_text().rsplit("\n", 2)[0] + "\n")  # a pair (f, r) missing
    r = CliRunner().invoke(cli, [*args, "--out", str(tmp_path / "never.zarr")])
    assert r.exit_code == 2 and "needs one row per pair" in r.output and r.output.count("\n") == 1, r.output
    assert not (tmp_path / "never.zarr").exists()
