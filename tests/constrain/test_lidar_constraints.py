"""Lidar line-of-sight constraints: the virtual lidar's operator, its adjoint, its streams, and the loop
truth -> `turbgen lidar --out` -> constrained field -> the virtual lidar re-measures the data."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.virtual_lidar.dataset import read_dataset
from turbgen.virtual_lidar.description import lidar_from_mapping
from turbgen.virtual_lidar.run import measurements_of
from turbgen.virtual_lidar.sampling import apply_los, check_measurements, los_operator
from turbgen.runs.constrain import place
from turbgen.spec.mann import MannRun
from turbgen.synthesis.conditioning import measure

LIDAR = {"name": "small", "kind": "pulsed", "mount": "nacelle", "ranges_m": [20, 40], "beam_rate_hz": 1.0,
         "rotor_radius_m": 10, "azimuth_deg": [10, -10], "elevation_deg": [5, -5], "fwhm_m": 4}  # fmt: skip


def adjoint_los(op, v: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """H^T v: the field (nx, 3, nt, ny, nz) that the values ``v`` (n_scan, J) scatter back to through the operator's
    weights, so that <H x, v> = <x, H^T v>."""
    out = np.zeros(shape)
    for j in range(op.weight.shape[1]):
        for c in np.flatnonzero(op.n[j]):
            np.add.at(out[op.plane[j], c], (op.t_index[:, j], op.y_index[j][None], op.z_index[j][None]),
                      op.n[j, c] * op.weight[:, j] * v[:, j, None])
    return out


GRID = ["--nt", "256", "--ny", "8", "--nz", "8", "--dy", "5", "--planes", "0,20,40", "--threads", "1"]


def _operator():
    run = MannRun.from_mapping({"grid": {"nt": 256, "dt_s": 0.5, "x_m": [0.0, 20.0, 40.0], "ny": 8, "nz": 8,
                                         "dy_m": 5.0}})  # fmt: skip
    ms = measurements_of(lidar_from_mapping(LIDAR))
    planes = check_measurements(SimpleNamespace(grid=run.grid), ms)
    times = np.stack([np.arange(60) * 2.0 + m.beam for m in ms], axis=1)  # each beam every 2 s
    return run, ms, los_operator(run.grid, run.U_m_s, ms, planes, times)


def test_adjoint_of_the_lidar_operator():
    run, _, op = _operator()
    g = run.grid
    rng = np.random.default_rng(0)
    x = rng.normal(size=(g.nx, 3, g.nt, g.ny, g.nz))
    y = rng.normal(size=op.weight.shape[:2])

    def read(c, ix, t, yy, zz):
        return x[ix, "uvw".index(c), t[0] : t[1], yy[0] : yy[1], zz[0] : zz[1]]

    hx = apply_los(op, read)
    hty = adjoint_los(op, y, x.shape)
    assert abs(np.vdot(hx, y) - np.vdot(x, hty)) <= 1e-10 * abs(np.vdot(hx, y))
    assert np.abs(hx).max() > 0.1  # a real measurement, not zeros


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    d = tmp_path_factory.mktemp("loop")
    (d / "small.json").write_text(json.dumps(LIDAR))
    r = CliRunner()
    for args in (["mann", *GRID, "--seed", "1", "--out", str(d / "truth.zarr")],
                 ["lidar", "run", str(d / "truth.zarr"), "--lidar", str(d / "small.json"), "--rotor-radius", "10",
                  "--mean-wind", "--out", str(d / "truth_lidar.zarr")]):  # fmt: skip
        res = r.invoke(cli, args, prog_name="turbgen")
        assert res.exit_code in (0, 1), res.output  # lidar run: 1 = its coherence verdict, not an error
    return d


def test_lidar_streams_measure_what_the_virtual_lidar_measures(loop):
    data = read_dataset(loop / "truth_lidar.zarr")
    run = MannRun.from_mapping({"grid": {"nt": 256, "dt_s": 0.5, "x_m": [0.0, 20.0, 40.0], "ny": 8, "nz": 8,
                                         "dy_m": 5.0}})  # fmt: skip
    placed = place(run, [data])
    assert placed.streams.decimation == 4  # a scan every 2 s, dt 0.5 s
    from turbgen.store import open_store

    fs = open_store(loop / "truth.zarr")
    out = np.zeros(placed.data.shape)
    for ix in range(run.grid.nx):
        for c, name in enumerate("uvw"):
            measure(placed.streams, ix, c, fs.read_plane(name, ix).astype(float), out)
    ok = np.isfinite(placed.data)
    assert ok.sum() == data.v_los.size
    # the data are the truth's v_los (float32, mean wind removed): the streams re-measure them
    np.testing.assert_allclose(out[ok], placed.data[ok], rtol=0, atol=2e-5)


def test_constrained_field_reproduces_the_lidar_data(loop):
    d = loop
    r = CliRunner()
    res = r.invoke(cli, ["mann", *GRID, "--seed", "2", "--constrain", str(d / "truth_lidar.zarr"),
                         "--out", str(d / "c.zarr")], prog_name="turbgen")  # fmt: skip
    assert res.exit_code == 0, res.output
    res = r.invoke(cli, ["lidar", "run", str(d / "c.zarr"), "--lidar", str(d / "small.json"), "--rotor-radius", "10",
                         "--mean-wind", "--out", str(d / "re.zarr")], prog_name="turbgen")  # fmt: skip
    assert res.exit_code in (0, 1), res.output
    truth, again = read_dataset(d / "truth_lidar.zarr").v_los, read_dataset(d / "re.zarr").v_los
    np.testing.assert_allclose(again, truth, rtol=0, atol=1e-4)


def test_residuals_of_noisy_lidar_data_have_the_noise_variance(loop, tmp_path):
    # d = H u_t + eps_t with u_t a field of the model and eps_t ~ N(0, sigma^2): then the residual
    # d - H u_c = R S^-1 (d - H u_s - eps_s) + eps_s of a conditional sample has covariance exactly R = sigma^2 I
    # (Hoffman & Ribak 1991; E[(d - H u_s - eps_s)(...)^T] = 2 S), i.e. independent N(0, sigma^2) residuals. Their
    # mean square over n samples has relative sd sqrt(2 / n); 4 sd bounds it.
    from turbgen.runs.constrain import PlacedData, conditioned_planes, stream_system
    from turbgen.runs.mann import build_mann_stencil

    sigma = 0.3
    run = MannRun.from_mapping({"seed": 7, "grid": {"nt": 256, "dt_s": 0.5, "x_m": [0.0, 20.0, 40.0], "ny": 8,
                                                    "nz": 8, "dy_m": 5.0}})  # fmt: skip
    base = place(run, [read_dataset(loop / "truth_lidar.zarr")], sigma)
    eps_t = np.random.default_rng(11).normal(size=base.data.shape) * sigma
    placed = PlacedData(base.streams, base.data + eps_t, base.noise_m_s, base.geometry)
    stencil = build_mann_stencil(run)
    _, planes = conditioned_planes(run, stencil, placed, stream_system(run, stencil, placed), tmp_path, threads=1)
    remeasured = np.zeros(placed.data.shape)
    for ix, comp, value in planes:
        measure(placed.streams, ix, "uvw".index(comp), value.astype(float), remeasured)
    ok = np.isfinite(placed.data)
    ratio = np.mean((placed.data[ok] - remeasured[ok]) ** 2) / sigma**2
    assert abs(ratio - 1.0) < 4 * np.sqrt(2.0 / ok.sum()), (ratio, ok.sum())
