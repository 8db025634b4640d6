"""turbgen.exporters.field_files: a .bts and the HAWC2 boxes of an htc read back as a field, and fitted as DATA."""

from __future__ import annotations

import numpy as np
import pytest

import turbgen
from turbgen.errors import ParameterError
from turbgen.exporters.bts import read_bts
from turbgen.exporters.field_files import open_wind_file


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A frozen Mann field on its own periodic box (pad_yz 1) and its .bts and HAWC2 exports: the smallest grid the
    fits take (what is checked, read-back and fit equality, holds at any size)."""
    d = tmp_path_factory.mktemp("wind")
    ds = turbgen.mann(L=30, gamma=3.2, ae=0.08, nt=512, ny=6, nz=6, dy=6, dz=6, planes=[0], evo=None, U=12,
                      seed=11, pad_yz=1)
    htc = next(p for p in turbgen.export(ds, "hawc2", d / "box").paths if p.suffix == ".htc")
    bts = turbgen.export(ds, "bts", d / "f.bts").paths[0]
    return ds, htc, bts


def _fluctuations(a: np.ndarray) -> np.ndarray:
    return a - a.mean(axis=0)


def test_the_files_read_back_as_the_field(exported):
    """The fluctuations equal the field's: HAWC2 boxes to float32 round-off of the added mean profile (|u| < 10 m/s
    plus a profile near 12 m/s: ulp 1e-6), a .bts to half its int16 quantisation step per component."""
    ds, htc, bts = exported
    hawc2, b = open_wind_file(htc), open_wind_file(bts)
    raw = read_bts(bts)
    for c in "uvw":
        truth = _fluctuations(ds[c].values[:, 0])
        assert np.abs(_fluctuations(hawc2[c].values[:, 0]) - truth).max() < 4e-6
        quantum = (raw[c].max() - raw[c].min()) / 65535  # the .bts spans its int16 range per component
        assert np.abs(_fluctuations(b[c].values[:, 0]) - truth).max() < quantum
    assert hawc2.attrs["grid"]["dt_s"] == pytest.approx(0.5) and hawc2.attrs["U_m_s"] == pytest.approx(12)


def test_fit_of_the_htc_is_the_fit_of_the_field(exported):
    """The field was made on a box of its own size (pad_yz 1), the model the boxes are fitted against: the fitted
    values agree to the float32 round-off the mean profile leaves."""
    ds, htc, _ = exported
    a, b = turbgen.fit_mann(ds), turbgen.fit_mann(htc)
    for name in ("ae", "length_scale_m", "gamma"):
        assert getattr(b, name).value == pytest.approx(getattr(a, name).value, rel=1e-6)
    assert repr(a) == a.table() and len(repr(a)) < 2000  # a notebook shows the table, not the band arrays
    assert type(a.plot()).__name__ == "Figure"  # a notebook cell shows it; nothing written without a path


def test_bad_wind_files_are_one_line(exported, tmp_path):
    _, htc, _ = exported
    text = htc.read_text()
    cases = {
        "no.htc": (text.replace("begin mann", "begin other"), "no 'begin mann ... end mann' block"),
        "missing.htc": (text.replace("box_u.bin", "gone_u.bin"), "box file ./gone_u.bin is in neither"),
        "size.htc": (text.replace("box_dim_v 6", "box_dim_v 7"), "values, but the htc's box_dim_u/v/w give"),
    }
    for name, (body, message) in cases.items():
        path = htc.parent / name
        path.write_text(body)
        with pytest.raises(ParameterError, match=message):
            open_wind_file(path)
    with pytest.raises(ParameterError, match="must end in .bts or .htc"):
        open_wind_file(tmp_path / "f.wnd")


def test_fit_kaimal_reads_a_bts(exported):
    """fit_kaimal takes the same wind files: the .bts of the field gives the fit of the field read back from it."""
    ds, _, bts = exported
    a, b = turbgen.fit_kaimal(open_wind_file(bts)), turbgen.fit_kaimal(bts)
    assert a.to_dict() == b.to_dict()
    assert repr(a) == a.table() and len(repr(a)) < 2000
    assert type(a.plot()).__name__ == "Figure"
