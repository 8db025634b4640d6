"""`turbgen theory ...` / `turbgen fit ...` through click's CliRunner: exit codes, JSON keys, plots."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.theory.mann_spectra import one_point_spectra
from turbgen.theory.params import MannParams

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run(*args):
    return CliRunner().invoke(cli, list(args))


def test_spectra_json_keys_and_values():
    r = run("theory", "spectra", "--L", "49", "--gamma", "3.1", "--ae", "0.311", "--k1", "0.001,0.01,0.1", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    assert {"k1", "F11", "F22", "F33", "F13"} <= set(out)
    assert out["k1"] == [0.001, 0.01, 0.1]
    expected = one_point_spectra(np.array(out["k1"]), MannParams(0.311, 49.0, 3.1))
    np.testing.assert_allclose(out["F11"], expected["F11"], rtol=1e-12)


def test_spectra_default_ae_is_iec_class_a(tmp_path):
    png = tmp_path / "s.png"
    r = run("theory", "spectra", "--f", "0.01,0.1", "--plot", str(png))
    assert r.exit_code == 0, r.output
    assert "F11" in r.output and png.read_bytes()[:8] == PNG_MAGIC


def test_longitudinal_json_and_plot(tmp_path):
    png = tmp_path / "l.png"
    r = run("theory", "longitudinal", "--f", "0.01,0.05,0.2", "--dx", "100", "--evo", "400", "--json",
            "--plot", str(png))
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    assert {"f", "coh2"} <= set(out) and len(out["coh2"]) == 3
    assert all(0 < c < 1 for c in out["coh2"]) and out["coh2"][0] > out["coh2"][2]
    assert png.read_bytes()[:8] == PNG_MAGIC


def test_coherence_and_rews_tables():
    r = run("theory", "coherence", "--f", "0.01,0.1", "--dy", "20", "--dz", "0")
    assert r.exit_code == 0, r.output
    assert "cocoh" in r.output.splitlines()[0]
    r = run("theory", "rews", "--f", "0.01,0.1", "--radius", "63", "--json")
    out = json.loads(r.output)
    assert all(s < f for s, f in zip(out["S_RR"], out["F11"]))


def test_fit_evolution_json():
    r = run("fit", "evolution", "--L", "49", "--gamma", "3.1", "--evo", "400", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    assert set(out) == {"a_x", "b_x"}
    assert out["a_x"] == pytest.approx(1.8, rel=0.1)


def test_fit_kaimal_table(tmp_path):
    png = tmp_path / "k.png"
    r = run("fit", "kaimal", "--f", ",".join(str(x) for x in np.linspace(0.002, 1.0, 100)), "--plot", str(png))
    assert r.exit_code == 0, r.output
    assert "a_yz" in r.output and png.read_bytes()[:8] == PNG_MAGIC


@pytest.mark.parametrize(
    "args",
    [
        ("theory", "spectra", "--L", "0"),
        ("theory", "spectra", "--L", "-5"),
        ("theory", "longitudinal", "--U", "0"),
        ("theory", "longitudinal", "--evo", "-1"),
        ("theory", "coherence", "--gamma", "nan"),
        ("theory", "spectra", "--gamma", "-1"),
        ("fit", "evolution", "--evo", "0"),
        ("theory", "spectra", "--ae", "1", "--ti", "0.1"),
        ("theory", "spectra", "--k1", "-0.1"),
    ],
)
def test_bad_input_exit_2(args):
    r = CliRunner(mix_stderr=False).invoke(cli, list(args)) if _has_mix_stderr() else run(*args)
    assert r.exit_code == 2
    err = r.stderr if _has_mix_stderr() else r.output
    assert len(err.strip().splitlines()) == 1 and "Error" in err


def _has_mix_stderr():
    import inspect

    return "mix_stderr" in inspect.signature(CliRunner.__init__).parameters
