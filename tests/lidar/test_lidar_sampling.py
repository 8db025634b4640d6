"""Virtual lidar sampling against exact limits on synthetic stores (no theory needed)."""

import numpy as np
import pytest

from turbgen.errors import ParameterError
from turbgen.grid import Grid
from turbgen.virtual_lidar import sampling, signals
from turbgen.virtual_lidar.sampling import Measurement
from turbgen.store import create_store, layout, open_store
from turbgen.validation.estimators import WelchSetup
from turbgen.validation.point_sets import rotor_mask

U = 20.0
GRID = Grid(nt=64, dt_s=0.5, x_m=(0.0, 40.0, 80.0), ny=9, nz=7, dy_m=5.0, dz_m=5.0)  # x/U = 0, 4, 8 samples


def make_store(path, grid=GRID, seed=0):
    rng = np.random.default_rng(seed)
    data = {c: rng.standard_normal(grid.shape).astype(np.float32) for c in layout.COMPONENTS}
    attrs = {"model": "mann", "parameters": {"L_m": 49.0}, "units": {"L_m": "m"}, "seed": seed,
             "U_m_s": U, "hub_height_m": 100.0}
    with create_store(path, grid, attrs) as w:
        for c in layout.COMPONENTS:
            for ix in range(grid.nx):
                w.write(c, ix, data[c][:, ix])
    return open_store(path), data


def schedule(n, nb, step):
    return np.arange(n * nb) * step, np.tile(np.arange(nb), n)


def test_beam_along_x_vanishing_probe_volume_is_u_at_gate(tmp_path):
    fs, d = make_store(tmp_path / "s.zarr")
    y, z = GRID.y(), GRID.z()
    ms = [Measurement(0, g, (1.0, 0.0, 0.0), (x, y[6], z[2]), direction=(1.0, 0.0, 0.0))
          for g, x in enumerate((40.0, 80.0))]
    t, b = schedule(60, 1, 0.5)
    s = sampling.sample(fs, ms, t, b)
    n = s.v_los.shape[0]
    # physical time T at plane x is stored sample T + x/U: 4 and 8 samples later
    np.testing.assert_array_equal(s.v_los[:, 0, 0], d["u"][4 : 4 + n, 1, 6, 2])
    np.testing.assert_array_equal(s.v_los[:, 0, 1], d["u"][8 : 8 + n, 2, 6, 2])
    assert n == (63 - 8) + 1  # every schedule entry whose farthest stored time is inside the store


def test_projection_bilinear_and_taylor_in_probe_volume(tmp_path):
    fs, d = make_store(tmp_path / "s.zarr")
    y, z = GRID.y(), GRID.z()
    a = np.deg2rad(20.0)
    n = (np.cos(a), np.sin(a) * np.cos(0.3), np.sin(a) * np.sin(0.3))
    # midway between y nodes 3 and 4, on z node 1; probe points one time step apart along x
    step = U * GRID.dt_s
    m = Measurement(0, 0, n, (40.0, (y[3] + y[4]) / 2, z[1]), offsets_m=(-step, 0.0, step),
                    weights=(0.25, 0.5, 0.25), direction=(1.0, 0.0, 0.0))
    t, b = schedule(30, 1, 0.5)
    s = sampling.sample(fs, [m], t, b)
    k = s.v_los.shape[0]
    exp = 0.0
    for off, w in zip((-1, 0, 1), (0.25, 0.5, 0.25)):
        sl = slice(4 + off, 4 + off + k)  # Taylor: point x_g + off*step at plane x_g, stored t = T + x'/U
        for c, nc in zip("uvw", n):
            exp = exp + w * nc * 0.5 * (d[c][sl, 1, 3, 1].astype(float) + d[c][sl, 1, 4, 1])
    np.testing.assert_allclose(s.v_los[:, 0, 0], exp, rtol=0, atol=2e-6)


def test_mean_wind_added_with_shear(tmp_path):
    fs, d = make_store(tmp_path / "s.zarr")
    z = GRID.z()
    m = Measurement(0, 0, (1.0, 0.0, 0.0), (40.0, 0.0, z[6]), direction=(1.0, 0.0, 0.0))
    t, b = schedule(10, 1, 0.5)
    s0 = sampling.sample(fs, [m], t, b)
    s1 = sampling.sample(fs, [m], t, b, add_mean_wind=True, shear_exponent=0.2)
    np.testing.assert_allclose(s1.v_los - s0.v_los, U * ((100.0 + z[6]) / 100.0) ** 0.2, rtol=1e-6)
    assert s1.mean_wind_added and not s0.mean_wind_added


def test_whole_rotor_disc_at_rotor_plane_gives_unit_coherence(tmp_path):
    grid = Grid(nt=1024, dt_s=0.25, x_m=(0.0, 40.0), ny=9, nz=9, dy_m=5.0, dz_m=5.0)
    fs, _ = make_store(tmp_path / "s.zarr", grid)
    mask = rotor_mask(grid, 20.0)
    iy, iz = np.nonzero(mask)
    ms = [Measurement(0, g, (1.0, 0.0, 0.0), (0.0, grid.y()[j], grid.z()[k]), direction=(1.0, 0.0, 0.0))
          for g, (j, k) in enumerate(zip(iy, iz))]
    t, b = schedule(1000, 1, 0.25)
    s = sampling.sample(fs, ms, t, b)
    ta, ull = signals.lidar_estimate(s, U)
    urr, _ = signals.rotor_average(fs, 20.0, ta)
    np.testing.assert_allclose(ull, urr, atol=1e-6)
    r = signals.welch_rl(ull, urr, WelchSetup(128, 0.25))
    assert np.all(r["coh2_RL"][1:] > 1 - 1e-6)
    np.testing.assert_allclose(r["G_RL"][1:], 1.0, atol=1e-5)


@pytest.mark.parametrize(
    "focus, offsets, weights, match",
    [
        ((100.0, 0.0, 0.0), (0.0,), (1.0,), "beyond the store's planes"),
        ((50.0, 0.0, 0.0), (0.0,), (1.0,), "between the store's planes"),
        ((40.0, 19.0, 0.0), (-10.0, 0.0, 10.0), (0.25, 0.5, 0.25), "leaves the yz field"),
        ((40.0, 0.0, 0.0), (0.0,), (0.0,), "summing to 1"),
    ],
)
def test_bad_geometry_is_one_line_parameter_error(tmp_path, focus, offsets, weights, match):
    fs, _ = make_store(tmp_path / "s.zarr")
    # a beam 14 deg off axis towards +y: the probe volume around y = 19 m crosses the field edge y = 20 m
    m = Measurement(0, 0, (1.0, 0.0, 0.0), focus, offsets, weights, direction=(np.cos(0.25), np.sin(0.25), 0.0))
    with pytest.raises(ParameterError, match=match) as e:
        sampling.sample(fs, [m], *schedule(10, 1, 0.5))
    assert "\n" not in str(e.value)
