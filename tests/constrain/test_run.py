"""Constrained Mann runs end to end: data placed on the grid, zero-noise interpolation of the store, the ensemble
of conditional samples against dense Gaussian conditioning, and the CLI's refusals and records."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.runs.constrain import _on_grid, conditioned_planes, place, run_mann_constrained, stream_system
from turbgen.runs.mann import build_mann_stencil
from turbgen.spec.constraints import point_series_from_mapping
from turbgen.spec.mann import MannRun
from turbgen.store import open_store
from turbgen.synthesis.mann_oracle import slab_factor
from turbgen.synthesis.prior_spectrum import slab_inv_tau, slab_weight
from turbgen.validation import validate

GRID = {"nt": 128, "dt_s": 0.5, "x_m": [0.0, 40.0], "ny": 4, "nz": 4, "dy_m": 10.0}
SMALL = ["--nt", "128", "--ny", "4", "--nz", "4", "--dy", "10", "--planes", "0,40", "--threads", "1"]


def _mast(t_s, total=True, U=16.0):
    """A mast at the rotor (off-grid y, z: bilinear) with u (total wind) and w, and a sensor on the gate plane with
    v, sampled at 4 Hz (the field has 2 Hz): values on the grid are interpolated. One gap in u."""
    u = U * total + 1.5 * np.sin(t_s / 3.0)
    u[20:25] = np.nan
    return {
        "kind": "point-series", "name": "mast", "time_s": list(t_s), "total_wind": total,
        "sensors": [
            {"name": "hub", "x_m": 0.0, "y_m": 3.0, "height_m": 150.0 - 4.0,
             "u_m_s": [None if math.isnan(v) else v for v in u], "w_m_s": list(0.4 * np.cos(t_s / 2.0))},
            {"name": "gate", "x_m": 40.0, "y_m": -10.0, "z_m": 5.0, "v_m_s": list(0.8 * np.sin(t_s / 5.0 + 1))},
        ],
    }  # fmt: skip


def _bilinear(fs, comp, plane, y, z):
    g = fs.grid
    field = fs.read_plane(comp, plane).astype(float)
    fy = (y - g.y()[0]) / g.dy_m
    fz = (z - g.z()[0]) / g.dz_m
    iy, iz = int(fy), int(fz)
    ay, az = fy - iy, fz - iz
    return ((1 - ay) * (1 - az) * field[:, iy, iz] + ay * (1 - az) * field[:, iy + 1, iz]
            + (1 - ay) * az * field[:, iy, iz + 1] + ay * az * field[:, iy + 1, iz + 1])  # fmt: skip


def test_zero_noise_store_reproduces_the_data(tmp_path):
    run = MannRun.from_mapping({"seed": 3, "grid": GRID})
    t = np.arange(0.0, 25.0, 0.25)  # the gate plane is 40 / 16 = 2.5 s later in stored time: within the record
    mapping = _mast(t)
    summary = run_mann_constrained(run, tmp_path / "c.zarr", [point_series_from_mapping(mapping, "mast.json")],
                                   threads=1)  # fmt: skip
    fs = open_store(tmp_path / "c.zarr")
    tn = run.grid.t()
    checked = 0
    # total u minus the exports' default mean wind, the power law alpha 0.2, at the mast's height 146 m (hub 150 m)
    for sensor, comp, shift in [(0, "u", 16.0 * (146.0 / 150.0) ** 0.2), (0, "w", 0.0), (1, "v", 0.0)]:
        s = mapping["sensors"][sensor]
        values = np.array([np.nan if v is None else v for v in s[f"{comp}_m_s"]]) - shift
        stored_t = t + s["x_m"] / run.U_m_s
        z = s.get("z_m", s.get("height_m", 0.0) - run.hub_height_m)
        expected = np.interp(tn, stored_t, values, left=np.nan, right=np.nan)  # NaN next to a gap, outside the span
        at = _bilinear(fs, comp, 0 if s["x_m"] == 0 else 1, s["y_m"], z)
        ok = np.isfinite(expected)
        assert ok.sum() > 20
        np.testing.assert_allclose(at[ok], expected[ok], rtol=0, atol=1e-4)
        checked += ok.sum()
    record = fs.attrs["constraints"]
    assert record["n_samples"] == checked and record["solver"]["method"] == "pcg"  # the gaps need the CG
    assert record["residual_max_m_s"] < 1e-4 and summary["constraints"] == record
    assert "the check applies only when the data came from the same model" in validate(fs, workers=1).table()


def _ou_factors(stencil, i, times):
    """exp(-|t_p - t_q| / tau_e) (P, P, nyp, nzp) of slab i (Guo et al. 2023, Eq. 13-14; ones when frozen)."""
    inv_tau = slab_inv_tau(stencil, i)
    if inv_tau is None:
        return np.ones((len(times), len(times), stencil.box.nyp, stencil.box.nzp))
    return np.exp(-np.abs(times[:, None] - times[None, :])[:, :, None, None] * inv_tau[None, None])


def _dense_prior(stencil, run):
    """Prior covariance of the stored field flattened (plane, component, t, y, z), by summing
    Re w_i rho Phi exp(i k r) over the box explicitly (one loop over slabs)."""
    g, box = run.grid, stencil.box
    idx = np.indices((g.nx, 3, g.nt, g.ny, g.nz)).reshape(5, -1).T
    p, c, n, y, z = idx.T
    cov = np.zeros((len(idx), len(idx)))
    jy, lz = np.arange(box.nyp), np.arange(box.nzp)
    ey = np.exp(2j * np.pi * np.outer(y, jy) / box.nyp)
    ez = np.exp(2j * np.pi * np.outer(z, lz) / box.nzp)
    for i in range(box.nk1):
        c_i = slab_factor(stencil, i)  # Phi_i = 2 C C^T
        phi, rho = 2.0 * np.einsum("ikyz,jkyz->ijyz", c_i, c_i), _ou_factors(stencil, i, run.plane_times_s())
        en = np.exp(2j * np.pi * i * n / box.nt)
        for a in range(len(idx)):
            kernel = rho[p[a]][p] * phi[c[a]][c]  # (points, nyp, nzp)
            ph = np.einsum("j,l,bj,bl->bjl", ey[a], ez[a], ey.conj(), ez.conj())
            cov[a] += slab_weight(stencil, i) * (en[a] * en.conj() * np.einsum("bjl,bjl->b", kernel, ph)).real
    return cov


@pytest.mark.slow
def test_ensemble_of_conditional_samples_matches_dense_conditioning(tmp_path):
    # 400 seeds on a 32 x 2 planes x 2 x 2 field, one sensor (u and w) with noise 0.3 m/s
    grid = {"nt": 32, "dt_s": 0.5, "x_m": [0.0, 16.0], "ny": 2, "nz": 2, "dy_m": 10.0}
    t = np.arange(0.0, 14.0, 0.5)
    mapping = {"kind": "point-series", "time_s": list(t), "noise_m_s": 0.3, "sensors": [
        {"x_m": 0.0, "y_m": 2.0, "z_m": -1.0, "u_m_s": list(1.5 * np.sin(t / 2.0)), "w_m_s": list(0.5 * np.cos(t))}]}
    files = [point_series_from_mapping(mapping, "m.json")]
    base = MannRun.from_mapping({"seed": 0, "grid": grid})
    stencil = build_mann_stencil(base)
    placed = place(base, files)
    cov_s = stream_system(base, stencil, placed)
    samples = []
    for seed in range(400):
        run = MannRun.from_mapping({"seed": seed, "grid": grid})
        _, planes = conditioned_planes(run, stencil, placed, cov_s, tmp_path, threads=1)
        field = np.zeros((2, 3, 32, 2, 2))
        for ix, comp, value in planes:
            field[ix, "uvw".index(comp)] = value
        samples.append(field.ravel())
    samples = np.array(samples)
    # dense reference: H from the streams (unit fields), prior by the explicit sum, numpy conditioning
    prior = _dense_prior(stencil, base)
    obs = np.isfinite(placed.data)
    h = np.zeros((placed.data.size, prior.shape[0]))
    from turbgen.synthesis.conditioning import measure

    for col in range(prior.shape[0]):
        unit = np.zeros(prior.shape[0])
        unit[col] = 1.0
        out = np.zeros(placed.data.shape)
        f = unit.reshape(2, 3, 32, 2, 2)
        for ix in range(2):
            for c in range(3):
                measure(placed.streams, ix, c, f[ix, c], out)
        h[:, col] = out.ravel()
    h = h[obs.ravel()]
    s = h @ prior @ h.T + 0.09 * np.eye(len(h))
    gain = np.linalg.solve(s, h @ prior).T
    mean = gain @ placed.data[obs]
    var = np.diag(prior - gain @ h @ prior)
    n = len(samples)
    # sample mean: sd sqrt(var / n); sample variance: relative sd sqrt(2 / (n - 1)) (normal data, chi-square);
    # 4.5 sd per point keeps the chance of a false failure over the 768 points below 1e-2
    z_mean = (samples.mean(axis=0) - mean) / np.sqrt(var / n)
    z_var = (samples.var(axis=0, ddof=1) / var - 1.0) / np.sqrt(2.0 / (n - 1))
    assert np.abs(z_mean).max() < 4.5, np.abs(z_mean).max()
    assert np.abs(z_var).max() < 4.5, np.abs(z_var).max()
    assert var.min() < 0.5 * np.diag(prior).min()  # the constraint matters: some points are pinned


def _write(path, mapping):
    path.write_text(json.dumps(mapping))
    return str(path)


def bad_cases(mast) -> list:
    """(name, file mapping, extra options, expected texts) of the refused constraint files, from a good ``mast``
    mapping (shared with the Kaimal runs' test)."""
    t = np.asarray(mast["time_s"])
    outside_y = json.loads(json.dumps(mast))
    outside_y["sensors"][0]["y_m"] = 100.0
    low = json.loads(json.dumps(mast))
    low["sensors"][0].pop("z_m", None)
    low["sensors"][0]["height_m"] = 10.0
    late = json.loads(json.dumps(mast))
    late["time_s"] = list(t + 100.0)
    empty = json.loads(json.dumps(mast))
    empty["sensors"][1]["v_m_s"] = [None] * len(t)
    off_plane = json.loads(json.dumps(mast))
    off_plane["sensors"][1]["x_m"] = 20.0
    return [
        ("schema", {"kind": "point-series", "time_s": [0, 1], "sensors": [{"x_m": 0, "y_m": 0}]}, [],
         ["constraint file", "sensors"]),
        ("outside-y", outside_y, [], ["y = 100 m is outside the field"]),
        ("below-the-field", low, [], ["hub: z (height 10 m less the hub height 150 m, --hub-height) = -140 m is "
                                      "outside the field"]),
        ("outside-time", late, [], ["outside the field's record"]),
        ("all-missing", empty, [], ["v_m_s has no value"]),
        ("not-a-plane", off_plane, [], ["x = 20 m is not a plane of the run"]),
        ("noise-negative", mast, ["--noise", "-0.5"], ["noise = -0.5 m/s must be a finite number in [0, 100]"]),
        ("noise-1e308", mast, ["--noise", "1e308"], ["noise = 1e+308 m/s must be a finite number in [0, 100]"]),
    ]  # fmt: skip


def assert_refused(tmp_path, command: list, case) -> None:
    """``turbgen *command --constrain FILE`` with the bad case ``case`` (of bad_cases): one line on standard error,
    exit 2, nothing on standard output and no store."""
    name, mapping, extra, expected = case
    path = _write(tmp_path / f"{name}.json", mapping)
    res = CliRunner().invoke(cli, [*command, "--constrain", path, *extra, "--out", str(tmp_path / "c.zarr")],
                             prog_name="turbgen")  # fmt: skip
    lines = res.stderr.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1 and res.stdout == "", (res.exit_code, res.output)
    for text in expected:
        assert text in lines[0], (text, lines[0])
    assert not (tmp_path / "c.zarr").exists()


@pytest.mark.parametrize("case", range(8))
def test_bad_constraints_are_one_line_exit_2_nothing_written(tmp_path, case):
    assert_refused(tmp_path, ["mann", *SMALL], bad_cases(_mast(np.arange(0.0, 20.0, 0.5)))[case])


def test_a_first_sample_just_before_the_record_counts_at_its_start():
    """A sensor's Taylor delay may put its first sample just before the record (a replay's sensor turned into the
    wind's frame): it counts at the first stored time, interpolated with the second; a span that leaves the record
    by more than its first or last sample interval is refused, as data outside the record always were."""
    run = MannRun.from_mapping({"U_m_s": 10.0, "grid": {"nt": 40, "dt_s": 0.5, "x_m": [0.0], "ny": 4, "nz": 4}})
    t = np.arange(0.0, 20.0, 0.5)
    out = _on_grid(run, t, t.copy(), -2.0, "s")  # stored times t - 0.2 s: -0.2 .. 19.3 s
    np.testing.assert_allclose(out[:-1], run.grid.t()[:-1] + 0.2, rtol=0, atol=1e-12)  # u = t at t = stored + 0.2
    assert np.isnan(out[-1])  # 19.5 s: after the last sample
    for x in (-6.0, 6.0):  # stored times -0.6 .. 18.9 s and 0.6 .. 20.1 s: the second sample outside
        with pytest.raises(ParameterError, match="outside the field's record 0 .. 19.5 s"):
            _on_grid(run, t, t.copy(), x, "s")


def test_out_of_core_runs_refuse_constraints(tmp_path):
    path = _write(tmp_path / "m.json", _mast(np.arange(0.0, 20.0, 0.5)))
    res = CliRunner().invoke(cli, ["mann", *SMALL, "--constrain", path, "--scheduler", "local", "--out",
                                   str(tmp_path / "c.zarr")], prog_name="turbgen")  # fmt: skip
    lines = res.stderr.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1 and "cannot take constraints" in lines[0], res.output
    assert not (tmp_path / "c.zarr").exists()


def test_dependent_zero_noise_series_are_refused_and_nothing_written(tmp_path):
    path = _write(tmp_path / "m.json", _mast(np.arange(0.0, 20.0, 0.5)))
    res = CliRunner().invoke(cli, ["mann", *SMALL, "--constrain", path, "--constrain", path, "--out",
                                   str(tmp_path / "c.zarr")], prog_name="turbgen")  # fmt: skip
    lines = res.stderr.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1, res.output
    # u and w of the hub sensor are both given twice: the smallest dependent set, in stream order, is the first
    # repeated series and the one it repeats (conditioning.dependent_set; the same on every CPU)
    assert "the measurements m.json:hub:u, m.json:hub:u are linearly dependent with zero noise" in lines[0]
    assert "gate" not in lines[0]
    assert not (tmp_path / "c.zarr").exists()


def test_conditional_mean_store_shown_by_info_and_refused_by_validate(tmp_path):
    path = _write(tmp_path / "m.json", _mast(np.arange(0.0, 20.0, 0.5)))
    out = str(tmp_path / "cm.zarr")
    res = CliRunner().invoke(cli, ["mann", *SMALL, "--constrain", path, "--noise", "0.2", "--conditional-mean",
                                   "--out", out], prog_name="turbgen")  # fmt: skip
    assert res.exit_code == 0, res.output
    info = CliRunner().invoke(cli, ["info", out], prog_name="turbgen")
    assert "constraints  conditional mean on 3 series" in info.stdout and "m.json:gate:v" in info.stdout
    res = CliRunner().invoke(cli, ["validate", out], prog_name="turbgen")
    assert res.exit_code == 2 and "holds the conditional mean of a constrained run" in res.stderr
    fs = open_store(out)
    u = fs.read_plane("u", 0)
    assert np.abs(u).max() < 5.0 and fs.attrs["constraints"]["conditional_mean"] is True


def test_progress_bars_on_a_terminal_and_none_otherwise(tmp_path, capsys, monkeypatch):
    run = MannRun.from_mapping({"seed": 3, "grid": GRID})
    files = [point_series_from_mapping(_mast(np.arange(0.0, 25.0, 0.25)), "mast.json")]
    run_mann_constrained(run, tmp_path / "quiet.zarr", files, threads=1, progress=True)
    assert capsys.readouterr().err == ""  # not a terminal: no bar
    monkeypatch.setattr(type(__import__("sys").stderr), "isatty", lambda self: True, raising=False)
    run_mann_constrained(run, tmp_path / "shown.zarr", files, threads=1, progress=True)
    err = capsys.readouterr().err
    for stage in ("system", "pass 1", "correction", "write"):
        assert f"{stage}: 100%" in err, err


def test_a_sample_at_the_last_time_step_next_to_a_gap_is_kept():
    # the value at t = (nt - 1) dt with its previous value missing was dropped (linear weights 0 x NaN)
    run = MannRun.from_mapping({"seed": 3, "grid": GRID})
    u = [None] * GRID["nt"]
    u[-1] = 1.5
    mapping = {"kind": "point-series", "name": "last", "time_s": [0.5 * i for i in range(GRID["nt"])],
               "sensors": [{"name": "m", "x_m": 0.0, "y_m": 0.0, "z_m": 0.0, "u_m_s": u}]}  # fmt: skip
    placed = place(run, [point_series_from_mapping(mapping, "last.json")])
    assert np.isfinite(placed.data).sum() == 1 and placed.data[0, -1] == 1.5
