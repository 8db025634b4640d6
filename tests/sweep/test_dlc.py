"""IEC design-load-case sets: DLC 1.2 class IIB at a reduced grid as one `turbgen sweep --dlc`, its manifest
listing every field's wind file and InflowWind input file; the NTM/ETM sigma1 and the speeds of a set."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.exporters import read_bts
from turbgen.spec.dlc import DlcSet
from turbgen.store import open_store


def test_speeds_and_sigma1():
    d = DlcSet("1.2", "IIB", 4, 24)
    assert d.speeds_m_s() == tuple(float(v) for v in range(4, 25, 2))
    assert DlcSet("1.1", "IA", 3, 25).speeds_m_s()[-2:] == (23.0, 25.0)
    assert DlcSet("1.1", "IA", 3.5, 25).speeds_m_s()[-2:] == (23.5, 25.0)  # V_out is always included
    assert d.sigma1_m_s(10.0) == pytest.approx(0.14 * (0.75 * 10 + 5.6))  # NTM, category B
    # ETM, class II (V_ave = 0.2 * 42.5), category B, c = 2 m/s
    etm = DlcSet("1.3", "IIB").sigma1_m_s(10.0)
    assert etm == pytest.approx(2 * 0.14 * (0.072 * (8.5 / 2 + 3) * (10.0 / 2 - 4) + 10))
    assert etm > d.sigma1_m_s(10.0)


@pytest.mark.parametrize("args,msg", [
    (("2.1", "IIB"), "DLC = '2.1' is not one of"),
    (("1.2", "IVB"), "is not I, II or III"),
    (("1.2", "IIB", 4, 50), "V_out (m/s) = 50 is outside the allowed range [4, 42.5]"),
    (("1.2", "IIB", 10, 8), "V_out (m/s) = 8 is outside"),
    (("1.2", "IIB", 4, 24, (1, 1)), "without duplicates"),
])
def test_bad_sets_refused(args, msg):
    with pytest.raises(ParameterError) as err:
        DlcSet(*args)
    assert msg in str(err.value)


def test_dlc12_class_iib_as_one_sweep(tmp_path):
    reader = pytest.importorskip("openfast_io.FAST_reader")
    out = tmp_path / "dlc12"
    res = CliRunner().invoke(cli, ["sweep", "--dlc", "1.2", "--iec-class", "IIB", "--v-in", "4", "--v-out", "8",
                                   "--seeds", "1-2", "--nt", "32", "--dt", "0.5", "--ny", "4", "--nz", "4",
                                   "--dy", "8", "--planes", "0", "--hub-height", "90", "--workers", "1",
                                   "--out", str(out)])
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader((out / "dlc_manifest.csv").open()))
    planned = {(v, s) for v in (4.0, 6.0, 8.0) for s in (1, 2)}
    assert {(float(r["V_hub_m_s"]), int(r["seed"])) for r in rows} == planned and len(rows) == len(planned)
    for r in rows:
        assert (r["dlc"], r["class"], r["model"]) == ("1.2", "IIB", "kaimal")
        V = float(r["V_hub_m_s"])
        sigma1 = 0.14 * (0.75 * V + 5.6)
        assert float(r["TI"]) == pytest.approx(sigma1 / V, rel=1e-5)
        fs = open_store(out / r["store"])
        assert fs.U_m_s == V and fs.attrs["parameters"]["sigma_m_s"][0] == pytest.approx(sigma1)
        assert fs.attrs["seed"] == int(r["seed"])
        b = read_bts(out / r["file"])
        assert b["U_m_s"] == pytest.approx(V) and b["hub_height_m"] == 90.0
        dat = out / r["inflowwind_file"]
        rd = reader.InputReader_OpenFAST()
        rd.FAST_directory = str(dat.parent)
        rd.fst_vt["Fst"]["InflowFile"] = dat.name
        rd.read_InflowWind()
        assert Path(rd.fst_vt["InflowWind"]["FileName_BTS"]) == out / r["file"]
    files = sorted(p.name for p in (out / "wind").iterdir())
    assert len(files) == 2 * len(planned)  # a .bts and its input file per field, nothing else
    before = {p.name: p.stat().st_mtime_ns for p in (out / "wind").iterdir()}
    res = CliRunner().invoke(cli, ["sweep", "--dlc", "1.2", "--iec-class", "IIB", "--v-in", "4", "--v-out", "8",
                                   "--seeds", "1-2", "--nt", "32", "--dt", "0.5", "--ny", "4", "--nz", "4",
                                   "--dy", "8", "--planes", "0", "--hub-height", "90", "--workers", "1",
                                   "--out", str(out)])
    assert res.exit_code == 0, res.output  # resumed: stores and exports kept
    assert {p.name: p.stat().st_mtime_ns for p in (out / "wind").iterdir()} == before


def test_dlc_needs_class_and_refuses_presets(tmp_path):
    res = CliRunner().invoke(cli, ["sweep", "--dlc", "1.2", "--out", str(tmp_path / "d")])
    assert res.exit_code == 2 and "--iec-class" in res.output
    res = CliRunner().invoke(cli, ["sweep", "--dlc", "1.2", "--iec-class", "IIB", "--preset", "neutral",
                                   "--out", str(tmp_path / "d")])
    assert res.exit_code == 2 and "--preset" in res.output
    assert not (tmp_path / "d").exists()


def test_dlc_sets_take_the_models_with_a_sigma_rule_only(tmp_path):
    # the load case's sigma1 enters each model through its declared load_case rule (turbgen.spec.models); a model
    # without one is refused by name rather than given another model's rule
    from turbgen.sweep.dlc import make_dlc_plan

    with pytest.raises(ParameterError, match="'further' is not one of mann, kaimal"):
        make_dlc_plan(DlcSet("1.2", "IIB", 10, 12, (1,)), out=tmp_path / "t", model="further")
    assert not (tmp_path / "t").exists()


def test_a_further_model_brings_its_own_load_case_rule(monkeypatch):
    import turbgen.spec.dlc as dlc
    import turbgen.spec.models as models

    kaimal = models.declaration("kaimal")
    further, bare = replace(kaimal, name="further"), replace(kaimal, name="bare", load_case=None)
    monkeypatch.setattr(models, "_BY_NAME", {**models._BY_NAME, "further": further, "bare": bare})
    monkeypatch.setattr(dlc, "DECLARATIONS", (*models.DECLARATIONS, further, bare))
    d = DlcSet("1.2", "IIB", 10, 12, (1,))
    assert dlc.dlc_models() == ("mann", "kaimal", "further")
    assert d.run_mapping("further", 10.0, 1) == d.run_mapping("kaimal", 10.0, 1)
    with pytest.raises(ParameterError, match="'bare' is not one of mann, kaimal, further"):
        d.run_mapping("bare", 10.0, 1)


def test_mann_and_etm_plans_target_sigma1(tmp_path):
    from turbgen.sweep.dlc import make_dlc_plan
    from turbgen.theory.mann_spectra import ae_for_sigma_u

    d = DlcSet("1.3", "IA", 10, 12, (5, 6))
    plan = make_dlc_plan(d, out=tmp_path / "m", model="mann", grid={"nt": 32, "ny": 4, "nz": 4, "dy": 8})
    assert [(r.U_m_s, r.seed) for r in plan.runs] == [(10.0, 5), (10.0, 6), (12.0, 5), (12.0, 6)]
    for r in plan.runs:
        s1 = d.sigma1_m_s(r.U_m_s)  # ETM, category A
        assert s1 == pytest.approx(2 * 0.16 * (0.072 * (10.0 / 2 + 3) * (r.U_m_s / 2 - 4) + 10))
        assert r.run.params.ae == pytest.approx(ae_for_sigma_u(s1, r.run.params), rel=1e-12)
        assert r.name == f"mann_dlc1.3-IA_U{r.U_m_s:g}_seed{r.seed}"
