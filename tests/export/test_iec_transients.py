"""IEC 61400-1 Ed. 4 transients as InflowWind uniform wind files: every row against the standard's
formula (written here independently with math), the wind InflowWind makes of the columns equal to the
standard's V(y, z, t), the file read by weio, the input file by openfast-io; bad events refused."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.exporters.uniform_wind import export_transient
from turbgen.spec.iec_transient import COLUMNS, IecTransient

HUB, D, V = 90.0, 126.0, 12.0
SIGMA1 = 0.14 * (0.75 * V + 5.6)  # class B: I_ref = 0.14
LAMBDA1 = 42.0  # hub above 60 m


def read_uniform(path) -> dict:
    """Columns of a uniform wind file, name (``COLUMNS``) -> float array (``!`` lines skipped)."""
    rows = [line.split() for line in Path(path).read_text().splitlines() if line.strip() and not line.startswith("!")]
    data = np.asarray(rows, dtype=float)
    return {c: data[:, k] for k, c in enumerate(COLUMNS)}


def inflowwind_speed(cols, k, y, z):
    """InflowWind's uniform-wind horizontal speed at row k, point (0, y, z) (IfW_UniformWind, RefLength = D)."""
    v = cols["WindSpeed"][k]
    delta = math.radians(cols["WindDir"][k])
    return (v * (z / HUB) ** cols["VertShear"][k] + v * cols["HorizShear"][k] / D * (y * math.cos(delta))
            + v * cols["LinVShear"][k] / D * (z - HUB) + cols["GustSpeed"][k])


def iec_event(kind, tau):
    """The standard's speed change [m/s] or angle [deg] at event time tau (Sect. 6.3.3), class IIB, V_hub = 12."""
    if kind == "EOG":
        v_e1 = 0.8 * 1.4 * 42.5
        gust = min(1.35 * (v_e1 - V), 3.3 * SIGMA1 / (1 + 0.1 * D / LAMBDA1))
        t = min(max(tau, 0.0), 10.5)
        return -0.37 * gust * math.sin(3 * math.pi * t / 10.5) * (1 - math.cos(2 * math.pi * t / 10.5))
    if kind == "EDC":
        theta = 4 * math.degrees(math.atan(SIGMA1 / (V * (1 + 0.1 * D / LAMBDA1))))
        t = min(max(tau, 0.0), 6.0)
        return 0.5 * theta * (1 - math.cos(math.pi * t / 6.0))
    if kind == "ECD":
        t = min(max(tau, 0.0), 10.0)
        return 0.5 * 15.0 * (1 - math.cos(math.pi * t / 10.0)), 0.5 * (720.0 / V) * (1 - math.cos(math.pi * t / 10.0))
    t = min(max(tau, 0.0), 12.0)
    return (2.5 + 0.2 * 6.4 * SIGMA1 * (D / LAMBDA1) ** 0.25) * (1 - math.cos(2 * math.pi * t / 12.0))


@pytest.mark.parametrize("kind", ["EOG", "EDC", "ECD", "EWS-V", "EWS-H"])
def test_every_row_is_the_standards_formula(tmp_path, kind):
    event = IecTransient(kind, "IIB", V, HUB, D, start_s=5.0, duration_s=40.0, dt_s=0.1, sign=1)
    paths, usage = export_transient(event, tmp_path / f"{kind}.hh")
    cols = read_uniform(paths[0])
    t = cols["Time"]
    assert t[0] == 0.0 and t[-1] == 40.0 and np.all(np.diff(t) > 0)
    assert np.diff(t[(t >= 5.0) & (t <= 5.0 + {"EOG": 10.5, "EDC": 6, "ECD": 10}.get(kind, 12))]).max() <= 0.1 + 1e-9
    points = [(0.0, HUB), (-50.0, 40.0), (30.0, 140.0)]
    for k, tk in enumerate(t):
        e = iec_event(kind, tk - 5.0)
        for y, z in points:
            nwp = V * (z / HUB) ** 0.2
            expected = {"EOG": nwp + (e if kind == "EOG" else 0), "EDC": nwp,
                        "ECD": nwp + (e[0] if kind == "ECD" else 0),
                        "EWS-V": nwp + (z - HUB) / D * (e if kind == "EWS-V" else 0),
                        "EWS-H": nwp + y / D * (e if kind == "EWS-H" else 0)}[kind]
            got = inflowwind_speed(cols, k, y, z)
            assert got == pytest.approx(expected, rel=1e-9, abs=1e-8)  # %.10g rows
        if kind in ("EDC", "ECD"):
            angle = e if kind == "EDC" else e[1]
            assert cols["WindDir"][k] == pytest.approx(angle, rel=1e-9, abs=1e-9)
        else:
            assert cols["WindDir"][k] == 0.0


def test_read_by_weio_and_openfast_io(tmp_path):
    weio_wnd = pytest.importorskip("weio.fast_wind_file")
    reader = pytest.importorskip("openfast_io.FAST_reader")
    event = IecTransient("ECD", "IIB", V, HUB, D, sign=-1)
    (tmp_path / "w").mkdir()
    paths, _ = export_transient(event, tmp_path / "w" / "ecd.hh")
    df = weio_wnd.FASTWndFile(str(paths[0])).toDataFrame()
    np.testing.assert_allclose(df.iloc[:, 2].to_numpy(), read_uniform(paths[0])["WindDir"])
    assert df.iloc[-1, 2] == pytest.approx(-720.0 / V)  # full change, sign -
    r = reader.InputReader_OpenFAST()
    r.FAST_directory = str(tmp_path / "w")
    r.fst_vt["Fst"]["InflowFile"] = paths[1].name
    r.read_InflowWind()
    ifw = r.fst_vt["InflowWind"]
    assert ifw["WindType"] == 2 and ifw["RefHt_Uni"] == HUB and ifw["RefLength"] == D
    assert Path(ifw["FileName_Uni"]) == paths[0]


@pytest.mark.parametrize("args,msg", [
    (dict(start_s=55.0), "outside the record of 60 s"),
    (dict(start_s=-1.0), "transient start (s) = -1 is outside"),
    (dict(iec_class="IVB"), "is not I, II or III"),
    (dict(V_hub_m_s=45.0), "V_hub (m/s) = 45 is outside the allowed range (0, 42.5]"),
    (dict(kind="EOG", V_hub_m_s=42.0, iec_class="IIIB"), "outside the allowed range (0, 37.5]"),
    (dict(sign=2), "must be +1 or -1"),
    (dict(dt_s=5.0), "dt (s) = 5 is outside"),
    (dict(dt_s=1e-9), "dt (s) = 1e-09 is outside the allowed range [0.001,"),  # once a 78 GiB allocation
    (dict(rotor_diameter_m=200.0), "reaches the ground"),
])
def test_bad_events_are_refused(args, msg):
    fields = dict(kind="EDC", iec_class="IIB", V_hub_m_s=V, hub_height_m=HUB, rotor_diameter_m=D) | args
    with pytest.raises(ParameterError) as err:
        IecTransient(**fields)
    assert msg in str(err.value)


def test_cli_exit_2_nothing_written(tmp_path):
    res = CliRunner().invoke(cli, ["transient", "ecd", "--iec-class", "IIB", "--U", "12", "--hub-height", "90",
                                   "--rotor-diameter", "126", "--start", "55", "--out", str(tmp_path / "e.hh")])
    assert res.exit_code == 2 and "outside the record" in res.output and len(res.output.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())
    res = CliRunner().invoke(cli, ["transient", "eog", "--iec-class", "IA", "--U", "12", "--hub-height", "90",
                                   "--rotor-diameter", "126", "--dt", "1e-9", "--out", str(tmp_path / "e.hh")])
    assert res.exit_code == 2 and "dt (s) = 1e-09" in res.output and len(res.output.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())
    res = CliRunner().invoke(cli, ["transient", "ews-v", "--iec-class", "IA", "--U", "20", "--hub-height", "90",
                                   "--rotor-diameter", "126", "--sign", "-", "--out", str(tmp_path / "e.hh")])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.hh", "e_InflowWind_uniform.dat"]
    assert "use: OpenFAST: set InflowFile" in res.output
