"""The eddy-evolution time fitted to the longitudinal coherence (turbgen.validation.fit.evolution)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import turbgen
from turbgen.cli import cli
from turbgen.spec.constraints import PointSensor, PointSeries
from turbgen.validation.fit import load_fit_data
from turbgen.validation.fit.evo_cross import coherence_spectra_corr
from turbgen.validation.fit.evolution import _aligned, x_pairs

Z999_OVER_Z95 = 3.2905267314919255 / 1.959963984540054  # 99.9 % over 95 % two-sided normal quantiles
GRID = dict(L=30.0, gamma=3.2, ae=0.08, nt=1024, ny=12, nz=12, dy=6, dz=6, planes=[0, 100], U=10.0, dt=0.5)


@pytest.fixture(scope="module")
def evolving():
    return turbgen.mann(evo=100, seed=21, **GRID)


@pytest.fixture(scope="module")
def frozen():
    return turbgen.mann(evo="frozen", seed=22, **GRID)


def test_x_pairs_groups_points_at_one_y_z():
    xyz = ((0.0, 0.0, 0.0), (100.0, 0.0, 0.0), (0.0, 6.0, 0.0), (50.0, 6.0, 0.0), (100.0, 6.0, 0.0), (0.0, 9.0, 0.0))
    o, fifty, hundred = (0.0, 0.0), (50.0, 0.0), (100.0, 0.0)
    assert x_pairs(xyz) == {(o, hundred): [(0, 1), (2, 4)], (o, fifty): [(2, 3)], (fifty, hundred): [(3, 4)]}
    assert x_pairs(((0.0, 0.0, 0.0), (0.0, 0.0, 10.0))) == {}
    # sensor data: at one height, positions (x, y), apart across the wind too (never at one x)
    assert x_pairs(xyz, lateral=True) == {
        ((0.0, 0.0), (50.0, 6.0)): [(0, 3)], ((0.0, 0.0), (100.0, 0.0)): [(0, 1)], ((0.0, 0.0), (100.0, 6.0)): [(0, 4)],
        ((0.0, 6.0), (50.0, 6.0)): [(2, 3)], ((0.0, 6.0), (100.0, 0.0)): [(2, 1)], ((0.0, 6.0), (100.0, 6.0)): [(2, 4)],
        ((0.0, 9.0), (50.0, 6.0)): [(5, 3)], ((0.0, 9.0), (100.0, 0.0)): [(5, 1)], ((0.0, 9.0), (100.0, 6.0)): [(5, 4)],
        ((50.0, 6.0), (100.0, 0.0)): [(3, 1)], ((50.0, 6.0), (100.0, 6.0)): [(3, 4)]}


def test_recovery_on_two_planes_100_m_apart(evolving):
    """The true gamma (100 s) lies within the 99.9 % interval (the 95 % one widened by 3.29 / 1.96 in ln gamma on
    the side of the truth; fixed seed, deterministic); the frozen limit is excluded by far."""
    fit = turbgen.fit_mann(evolving)
    e = fit.evolution
    assert e is not None and e.identified and e.pairs_m == ((0.0, 100.0),)
    lo, hi = (math.log(v) for v in e.ci95)
    x = math.log(e.value_s)
    half = (x - lo) if math.log(100.0) < x else (hi - x)
    assert abs(x - math.log(100.0)) <= Z999_OVER_Z95 * half, (e.value_s, e.ci95)
    assert e.chi2_frozen - e.chi2 > 100 and e.chi2 / e.dof < 3
    # the one-point fit's uncertainty widens the coherence's own interval; the coherence fixes about L^2 / gamma
    assert e.ci95[0] < e.ci95_held[0] and e.ci95_held[1] < e.ci95[1] and 1.5 < e.sensitivity[1] < 2.5
    out = fit.to_dict()["evo_time_s"]
    assert out["identified"] and out["ci95"][0] < out["value"] < out["ci95"][1]
    assert any(n.startswith("evo_time_s identified") for n in fit.notes)
    assert "evo_time_s =" in fit.table()


def test_frozen_field_is_said_not_identified(frozen, tmp_path):
    """Planes of a frozen field are the same series in the convected frame (co-coherence 1 at float32 round-off):
    the interval reaches the frozen limit, and the result says so instead of a bounded gamma."""
    fit = turbgen.fit_mann(frozen)
    e = fit.evolution
    assert not e.identified and e.ci95[1] is None and e.chi2_frozen < 1
    assert np.all(np.abs(e.data[(0.0, 0.0), (100.0, 0.0)] - 1) < 1e-5) and e.lateral_m == (0.0,)
    assert any("frozen (Taylor) limit is inside the 95 % interval" in n for n in fit.notes)
    d = json.loads(json.dumps(fit.to_dict()))["evo_time_s"]
    assert d["ci95"][1] is None and not d["identified"]
    assert "inf (frozen)" in fit.table()
    fit.plot(tmp_path / "f.png")
    assert (tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"


def _masts(ds, iz=(3, 8)) -> PointSeries:
    """Two masts at the planes' (y, z) points, sampled at the same physical times: the mast at x sees at time T the
    stored sample T + x / U (x / (U dt) = 20 samples here); the records are the common span."""
    U, dt, nt = 10.0, 0.5, ds.sizes["t"]
    lag = round(100.0 / (U * dt))
    sensors = []
    for k, x in enumerate((0.0, 100.0)):
        shift = lag if k else 0
        for z in iz:
            series = {c: ds[c].values[shift: nt - lag + shift, k, 6, z].astype(float) for c in "uvw"}
            sensors.append(PointSensor(f"x{x:g}z{z}", x, float(ds.y[6]), float(ds.z[z]), None, series))
    return PointSeries("masts", ds.t.values[: nt - lag], tuple(sensors), False, None, "two masts")


def test_sensor_series_are_aligned_by_taylors_delay(evolving):
    """Sensor data are shifted back into the convected frame: the aligned columns are the stored ones (the span
    both masts saw, 20 samples shorter than the file) up to the line each sensor's detrending removed."""
    data = load_fit_data(_masts(evolving), U_m_s=10.0)
    u = _aligned(data)
    nt = evolving.sizes["t"]
    assert u.shape[0] == nt - 40
    for c, (k, z) in enumerate(((0, 3), (0, 8), (1, 3), (1, 8))):
        line = u[:, c] - evolving.u.values[20 : nt - 20, k, 6, z]
        assert np.max(np.abs(np.diff(line, 2))) < 1e-12


def test_the_part_of_taylors_delay_under_a_sample_is_in_the_model(frozen):
    """A frozen field's series and its copy 2.5 samples later (the Fourier shift of the periodic record), as masts
    12.5 m apart at U = 10 m/s: the alignment shifts by 2 samples, the remaining 0.25 s turns the cross-spectrum,
    so the measured co-coherence falls to cos(2 pi f 0.25 s) at high f with no evolution at all. The model carries
    that factor: the frozen limit stays inside the interval (a model without it read the fall as evolution)."""
    nt, dt, delay = frozen.sizes["t"], 0.5, 1.25
    turn = np.exp(2j * np.pi * np.fft.rfftfreq(nt, dt) * delay)  # the mast 12.5 m upstream sees the flow 1.25 s earlier
    sensors = [PointSensor(f"x{x:g}", x, float(frozen.y[6]), float(frozen.z[5]), None,
                           {c: np.fft.irfft(np.fft.rfft(frozen[c].values[:, 0, 6, 5].astype(float)) * turn**k, n=nt)
                            for c in "uvw"}) for k, x in enumerate((0.0, 12.5))]
    e = turbgen.fit_mann(PointSeries("m", np.arange(nt) * dt, tuple(sensors), False, None, "shifted"), U=10.0).evolution
    y = float(frozen.y[6])  # fluctuation data: positions as given
    assert e.pairs_m == ((0.0, 12.5),) and e.lateral_m == (0.0,)
    top = e.data[(0.0, y), (12.5, y)]
    assert top.min() < 0.8 and abs(top[-1] - math.cos(2 * np.pi * e.f_hz[-1] * 0.25)) < 0.1, (e.f_hz, top)
    assert not e.identified and e.ci95[1] is None, e.message


def test_one_x_only_is_not_fitted_and_said(evolving):
    """One mast (every sensor at x = 0): no pair along x; gamma is not fitted, the notes and the JSON say so."""
    ps = _masts(evolving)
    one = PointSeries("one", ps.time_s, ps.sensors[:2], False, None, "one mast")
    fit = turbgen.fit_mann(one, U=10.0)
    assert fit.evolution is None
    assert any(n.startswith("evo_time_s not fitted: the data hold no two u series") for n in fit.notes)
    assert fit.to_dict()["evo_time_s"] == {"value": None, "ci95": None, "held": True}


def test_cli_two_masts_json(evolving, tmp_path):
    """`turbgen fit mann` of a two-mast file prints evo_time_s with its interval (continuous model)."""
    ps = _masts(evolving)
    sensors = [{"name": s.name, "x_m": s.x_m, "y_m": s.y_m, "z_m": s.z_m,
                **{f"{c}_m_s": list(v) for c, v in s.series.items()}} for s in ps.sensors]
    path = tmp_path / "masts.json"
    path.write_text(json.dumps({"kind": "point-series", "time_s": list(ps.time_s), "sensors": sensors}))
    r = CliRunner().invoke(cli, ["fit", "mann", str(path), "--U", "10", "--json"])
    out = json.loads(r.output.splitlines()[0])
    e = out["evo_time_s"]
    assert e["pairs_m"] == [[0.0, 100.0]] and e["held"] is False
    assert e["ci95"][0] < e["value"] and (e["ci95"][1] is None or e["value"] < e["ci95"][1])


def _total_wind_masts(ds, iy: tuple, turn_deg: float) -> PointSeries:
    """Total-wind masts (U = 10 m/s) at planes 0 and 100 m, at y[iy[0]] and y[iy[1]], heights z[3] and z[8], in a
    file whose frame is the field's turned by ``turn_deg`` (positions and u, v; counter-clockwise from above)."""
    nt, lag = ds.sizes["t"], 20
    c, n = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
    y0, sensors = float(ds.y[iy[0]]), []
    for k, x in enumerate((0.0, 100.0)):
        y = float(ds.y[iy[k]]) - y0
        for z in (3, 8):
            u, v, w = (ds[ch].values[lag * k: nt - lag + lag * k, k, iy[k], z].astype(float) for ch in "uvw")
            sensors.append(PointSensor(f"m{k}z{z}", x * c + y * n, -x * n + y * c, float(ds.z[z]), None,
                                       {"u": (u + 10.0) * c + v * n, "v": -(u + 10.0) * n + v * c, "w": w}))
    return PointSeries("masts", ds.t.values[: nt - lag], tuple(sensors), True, None, "two masts")


def test_masts_off_the_wind_line_are_fitted_in_the_wind_s_frame(evolving):
    """Two masts 100 m apart along the wind and 18 m across it, in a file whose x runs along the mast line (the wind
    10.2 deg off it): the fit turns the positions into the wind's frame and fits gamma with the pair's lateral offset
    in the model (Phi_11 exp(i k2 dy)) -- the same L and gamma as the file in the field's own frame. Before, the masts
    were taken 101.6 m apart along the wind and gamma came out low (the lateral decorrelation read as evolution),
    and the field's own frame (the masts at two y) gave no pair at all."""
    iy = (3, 6)
    line = math.degrees(math.atan2(float(evolving.y[6] - evolving.y[3]), 100.0))
    fits = [turbgen.fit_mann(_total_wind_masts(evolving, iy, t)) for t in (0.0, line)]
    own, along_line = (f.evolution for f in fits)
    assert fits[1].length_scale_m.value == pytest.approx(fits[0].length_scale_m.value, rel=1e-6)  # the spectra's too
    (x0, x1), = own.pairs_m
    assert (x0, x1, *own.lateral_m) == pytest.approx((0.0, 100.0, 18.0), abs=0.05)  # the sample's direction: ~0.01 deg
    assert np.ravel(along_line.pairs_m) == pytest.approx(np.ravel(own.pairs_m), abs=1e-9)
    assert along_line.lateral_m == pytest.approx(own.lateral_m, abs=1e-9)
    for a, b in ((along_line.value_s, own.value_s), (along_line.chi2, own.chi2), (along_line.ci95[0], own.ci95[0])):
        assert a == pytest.approx(b, rel=1e-6)
    assert json.loads(json.dumps(fits[1].to_dict()))["evo_time_s"]["lateral_m"] == list(along_line.lateral_m)


def test_a_replay_of_masts_off_the_wind_places_them_in_the_wind_s_frame(evolving, tmp_path):
    """The file's x runs along the mast line, 10.2 deg off the wind: the replay turns the sensors' positions into the
    wind's frame as the fit does, so the second mast sits 18 m across the wind (not on the line of the first), on the
    plane of its file x (no plane at its turned x) with the Taylor delay of its turned x; the first, at the origin,
    stays. At zero noise the field passes through the data there (w: neither turned nor a mean taken off): the field
    interpolated across y at the turned y against the series interpolated to the times t - x/U."""
    line = math.degrees(math.atan2(float(evolving.y[6] - evolving.y[3]), 100.0))
    ps = _total_wind_masts(evolving, (3, 6), line)
    sensors = [{"name": s.name, "x_m": s.x_m, "y_m": s.y_m, "z_m": s.z_m,
                **{f"{c}_m_s": list(v) for c, v in s.series.items()}} for s in ps.sensors]
    path = tmp_path / "masts.json"
    path.write_text(json.dumps({"kind": "point-series", "time_s": list(ps.time_s), "total_wind": True,
                                "sensors": sensors}))
    planes = f"0,{ps.sensors[2].x_m!r}"  # the file's x of the second mast (101.6 m along the mast line)
    grid = ["--nt", "1152", "--dt", "0.5", "--ny", "12", "--nz", "12", "--dy", "6", "--dz", "6", "--planes", planes]
    r = CliRunner().invoke(cli, ["mann", "--constrain", str(path), "--fit", "--evo", "frozen", *grid, "--hub-height",
                                 "90", "--noise", "0", "--out", str(tmp_path / "r.zarr")])  # fmt: skip
    assert r.exit_code == 0, r.output
    ds = turbgen.open_store(tmp_path / "r.zarr")
    placed = ds.attrs["fit"]["placed"]
    assert sorted(placed) == ["m1z3", "m1z8"]  # the first mast, at the origin, does not move
    for name in placed:  # (100, 18) m in the field's frame; the data's direction is the field's to ~0.01 deg
        assert placed[name] == pytest.approx([100.0, 18.0], abs=0.05)
    assert "the sensors' x and y were turned too: m1z3 (" in r.output, r.output
    x, y = placed["m1z3"]
    s = next(s for s in sensors if s["name"] == "m1z3")
    t = ds.t.values
    expected = np.interp(t - x / ds.attrs["U_m_s"], ps.time_s, s["w_m_s"], left=np.nan, right=np.nan)
    iz = int(np.argmin(np.abs(ds.z.values - s["z_m"])))
    w = ds["w"].values[:, 1, :, iz].astype(float)  # plane 1: the file's x

    def across(at_y: float) -> np.ndarray:  # w linear in y between the nodes, as conditioning places a point
        j = int(np.searchsorted(ds.y.values, at_y)) - 1
        frac = (at_y - float(ds.y[j])) / float(ds.y[j + 1] - ds.y[j])
        return w[:, j] * (1 - frac) + w[:, j + 1] * frac

    ok = np.isfinite(expected)
    assert ok.sum() > 1000
    # float32 round-off of the synthesis's FFTs (as test_replay's pass-through: eps32 log2 N of the values)
    tol = np.finfo(np.float32).eps * math.log2(1152 * 24 * 24) * float(np.abs(w).max())
    assert np.abs(across(y)[ok] - expected[ok]).max() <= tol
    assert np.abs(across(0.0)[ok] - expected[ok]).max() > 100 * tol  # on the file's line, where it was placed before
    narrow = [*grid[:4], "--ny", "4", *grid[6:]]  # y from -9 to 9 m: the turned mast is outside, the file's inside
    r = CliRunner().invoke(cli, ["mann", "--constrain", str(path), "--fit", "--evo", "frozen", *narrow, "--hub-height",
                                 "90", "--out", str(tmp_path / "n.zarr")])  # fmt: skip
    assert r.exit_code == 2 and not (tmp_path / "n.zarr").exists(), r.output
    assert f"m1z3: y (turned into the wind's frame) = {y:g} m is outside the field (-9 .. 9 m)" in r.output, r.output


def test_incoherent_masts_give_only_an_upper_bound():
    """Independent noise at two masts 150 m apart: co-coherence 0, so gamma sits at the bottom of its range and only
    an upper bound is said (the one-point fit of noise is flagged on its own)."""
    rng = np.random.default_rng(3)
    t = np.arange(1024) * 0.5
    masts = [PointSensor(f"s{x:g}", x, 0.0, 0.0, None, {c: rng.standard_normal(t.size) for c in "uvw"})
             for x in (0.0, 150.0)]
    fit = turbgen.fit_mann(PointSeries("n", t, tuple(masts), False, None, "noise"), U=10.0)
    e = fit.evolution
    assert e.value_s == pytest.approx(1.0) and e.ci95[0] == 1.0 and e.ci95[1] < 100
    assert e.message.startswith("evo_time_s not identified from below")


def test_coherence_spectra_correlation_is_that_of_gaussian_dfts():
    """The Isserlis correlation of a pair's linearised co-coherence with each point-averaged spectrum equals that
    of Monte Carlo complex Gaussian DFTs with the same coherencies (6 points on two planes, u, v, w correlated);
    the sample correlation of n draws has sd (1 - kappa^2) / sqrt(n): agreement within 4 of those."""
    rng = np.random.default_rng(1)
    P, C, n = 3, 3, 100_000
    N = 2 * P
    A = rng.standard_normal((C * N, 2)) + 1j * rng.standard_normal((C * N, 2))
    S = A @ A.conj().T + 0.5 * np.diag(rng.uniform(1, 2, C * N))  # channel (component, site): component * N + site
    G = S / np.sqrt(np.outer(np.diag(S).real, np.diag(S).real))
    g = G.reshape(C, N, C, N).transpose(0, 2, 1, 3).reshape(1, C, C, N * N)  # separation index a * N + b
    sets = {"uu": np.arange(N), "vv": np.arange(N), "ww": np.arange(1, N), "uw": np.arange(N - 1)}
    a, c = np.arange(P), np.arange(P, N)
    kappa = coherence_spectra_corr(g, np.arange(N * N).reshape(N, N), [(a, c)], sets, tuple(sets))[0, 0]
    X = np.linalg.cholesky(G) @ (rng.standard_normal((C * N, n)) + 1j * rng.standard_normal((C * N, n)))
    rho = G[a, c].real.mean()
    z = (np.real(X[a] * np.conj(X[c])) - rho / 2 * (np.abs(X[a]) ** 2 + np.abs(X[c]) ** 2)).mean(axis=0)
    for m, s in enumerate(sets):
        i, j = ("uvw".index(ch) * N + sets[s] for ch in s)
        mc = np.corrcoef(z, np.real(X[i] * np.conj(X[j])).mean(axis=0))[0, 1]
        assert abs(kappa[m] - mc) < 4 * (1 - mc**2) / math.sqrt(n), (s, kappa[m], mc)
    assert np.max(np.abs(kappa)) > 0.1  # a case where the cross term matters


def test_replay_of_two_masts_takes_the_fitted_evolution_time(evolving, tmp_path):
    """`turbgen mann --constrain MASTS --fit`: sensors at two x identify gamma, so the replayed field is made with the
    fitted evolution time (rounded as L), the store and `turbgen info` say so, and a typed --evo is refused; the masts
    in two files give the same field."""
    ps = _masts(evolving)
    sensors = [{"name": s.name, "x_m": s.x_m, "y_m": s.y_m, "z_m": s.z_m,
                **{f"{c}_m_s": list(v) for c, v in s.series.items()}} for s in ps.sensors]
    path = tmp_path / "masts.json"
    path.write_text(json.dumps({"kind": "point-series", "time_s": list(ps.time_s), "sensors": sensors}))
    grid = ["--U", "10", "--nt", "1024", "--dt", "0.5", "--ny", "12", "--nz", "12", "--dy", "6", "--dz", "6",
            "--planes", "0,100"]
    r = CliRunner().invoke(cli, ["mann", "--constrain", str(path), "--fit", *grid, "--out", str(tmp_path / "r.zarr")])
    assert r.exit_code == 0, r.output
    ds = turbgen.open_store(tmp_path / "r.zarr")
    e = ds.attrs["fit"]["fit"]["evo_time_s"]
    fitted = float(f"{e['value']:.6g}")
    assert e["identified"] and e["pairs_m"] == [[0.0, 100.0]]
    assert ds.attrs["fit"]["run"]["evo_time_s"] == fitted == ds.attrs["parameters"]["evo_time_s"]
    assert f"eddy-evolution time {fitted:g} s [" in r.output
    # each mast in a file of its own (as two loggers write them): fitted as one, the same field to the bit
    for k, name in enumerate(("x0.json", "x100.json")):
        doc = {"kind": "point-series", "time_s": list(ps.time_s), "sensors": sensors[2 * k: 2 * k + 2]}
        (tmp_path / name).write_text(json.dumps(doc))
    two = turbgen.mann(constrain=[tmp_path / "x0.json", tmp_path / "x100.json"], fit=True, U=10, nt=1024, dt=0.5,
                       ny=12, nz=12, dy=6, dz=6, planes=[0, 100])
    assert [f["path"] for f in two.attrs["fit"]["files"]] == [str(tmp_path / "x0.json"), str(tmp_path / "x100.json")]
    assert two.attrs["fit"]["run"] == ds.attrs["fit"]["run"]
    for c in "uvw":
        np.testing.assert_array_equal(two[c].values, ds[c].values)
    r = CliRunner().invoke(cli, ["mann", "--constrain", str(path), "--fit", *grid, "--evo", "frozen",
                                 "--out", str(tmp_path / "typed.zarr")])
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1, r.output
    assert "--evo with --fit (fit=True): the data along x identify the eddy-evolution time" in r.output
    assert not (tmp_path / "typed.zarr").exists()


def test_a_one_point_fit_at_the_top_of_l_s_range_still_gives_the_evolution_time():
    """Two 20 Hz masts of points cut from a narrow box (12 x 12 nodes 4 m apart): the continuous one-point fit lands
    on L = 1000 m (flagged), and gamma's interval carries its uncertainty by moving L one sd the other way; the
    secant stepped above the range and failed with "L (length scale, m) = 7916.9 is outside the allowed range"."""
    ds = turbgen.mann(L=30, gamma=3.2, ae=0.08, evo=100, U=10, nt=12000, dt=0.05, ny=12, nz=12, dy=4, planes=[0, 100],
                      hub_height=90, seed=3)
    sensors = [dict(name=f"s{x}_{k}", x_m=float(x), y_m=float(ds.y[6]), z_m=float(ds.z[k]),
                    **{f"{c}_m_s": ds[c].values[:, i, 6, k] for c in "uvw"})
               for i, x in enumerate((0, 100)) for k in (3, 9)]
    fit = turbgen.fit_mann(turbgen.point_series(ds.t.values, sensors), U=10)
    assert fit.length_scale_m.value > 999 and any("length_scale_m = 1000 is on the boundary" in f for f in fit.flags)
    assert fit.evolution is not None and fit.evolution.ci95[1] is not None and fit.evolution.sensitivity[1] != 0
