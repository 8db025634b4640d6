"""Exports read back by the real OpenFAST InflowWind: its ``inflowwind_driver`` (built from OpenFAST's source,
outside this repository, as docs/inflow.md "Verified against InflowWind" says) loads the InflowWind v5 input file
`turbgen export` writes beside the wind files and samples the wind at points upstream, on and between the grid
nodes, at times that wrap (periodic files) or start half a grid width upstream (non-periodic ones).

Its Velocity.dat is compared with values made here independently of the exporters: the store's fluctuations at
the grid nodes plus the mean wind written out from its formulas (power law, IEC 61400-1 Ed. 4 Sect. 6.3.2.2; log
law and veer, Jonkman 2009, TurbSim User's Guide; a user table linear in height), interpolated trilinearly in
(time, y, z) as InflowWind does, with InflowWind's Taylor shift T = t + (InitX - X) / U (InitX = half the grid width
for a non-periodic file, else 0; periodic files wrap modulo nt dt).

These tests run only when the environment variable TURBGEN_INFLOWWIND_DRIVER names the driver binary; otherwise
they are skipped with that reason. The skip is honest: CI has no Fortran build of OpenFAST, so there these
comparisons do not run; a developer who builds the driver runs them.
"""

from __future__ import annotations

import math
import os
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.runs.mann import run_mann
from turbgen.spec.mann import MannRun
from turbgen.store import open_store

DRIVER = os.environ.get("TURBGEN_INFLOWWIND_DRIVER")
pytestmark = pytest.mark.skipif(
    not DRIVER or not Path(DRIVER).is_file(),
    reason="TURBGEN_INFLOWWIND_DRIVER does not name an OpenFAST inflowwind_driver binary (CI has none)")

U, HUB, DT, NT, NY, NZ, DY, DZ = 10.0, 40.0, 0.25, 64, 8, 8, 4.0, 4.0
# (X, Y, Z) [m]: grid corners and nodes, points between nodes, upstream (X < 0) and downstream (X > 0) of the rotor
POINTS = [(0.0, -14.0, 26.0), (0.0, 14.0, 54.0), (0.0, 2.0, 42.0), (-5.0, 3.1, 40.0), (-12.5, -7.3, 47.9),
          (7.5, 0.0, 33.3)]
TABLE = [(20.0, 8.1, 4.0), (35.0, 9.6, 1.0), (40.0, 10.0, 0.0), (48.0, 10.9, -2.5), (60.0, 11.5, -6.0)]
HISTORY = [(0.5, 9.0, 0.0), (5.0, 11.0, 10.0), (12.0, 10.0, -5.0), (14.0, 9.5, 0.0)]  # t [s], U [m/s], dir [deg]


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ifw_driver")
    grid = {"nt": NT, "dt_s": DT, "x_m": [0.0], "ny": NY, "nz": NZ, "dy_m": DY, "dz_m": DZ}
    path = folder / "mann.zarr"
    run_mann(MannRun.from_mapping({"grid": grid, "U_m_s": U, "hub_height_m": HUB, "seed": 7, "evo_time_s": None}),
             path)
    table, history = folder / "profile.csv", folder / "history.csv"
    table.write_text("# z [m], U [m/s], direction [deg]\n" + "".join(f"{z},{u},{d}\n" for z, u, d in TABLE))
    history.write_text("t,U,direction\n" + "".join(f"{t},{u},{d}\n" for t, u, d in HISTORY))
    return path, table, history


def profile_and_veer(profile: str, veer: float, heights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Profile ratio U(h) / U(hub) [-] and veer angle [deg, counter-clockwise seen from above] at ``heights``, from
    the formulas."""
    kind, _, value = profile.partition(":")
    z = np.asarray(heights, dtype=float)
    if kind == "power":
        ratio = (z / HUB) ** float(value)
    elif kind == "log":
        z0, d = (float(item.split("=")[1]) for item in value.split(","))
        ratio = np.log((z - d) / z0) / math.log((HUB - d) / z0)
    else:
        tz, tu, td = (np.array(c) for c in zip(*TABLE))
        return np.interp(z, tz, tu) / np.interp(HUB, tz, tu), np.interp(z, tz, td) - np.interp(HUB, tz, td)
    return ratio, veer * (z - HUB)


def expected(store_path, profile: str, veer: float, history: bool, periodic: bool, t_x_y_z: np.ndarray,
             event=None) -> np.ndarray:
    """(N, 3) full velocities [m/s] at rows (T, X, Y, Z): node values (fluctuation + mean + an IEC ``event``'s speed
    terms, turned by the veer and the history's or event's direction at the time the slice reaches the turbine),
    trilinear in (slice time, y, z) at InflowWind's Taylor-shifted slice time."""
    fs = open_store(store_path)
    f = {c: fs.read_plane(c, 0).astype(np.float64) for c in "uvw"}
    heights, y_nodes = HUB + fs.grid.z(), fs.grid.y()
    ratio, angle = profile_and_veer(profile, veer, heights)
    init_x = 0.0 if periodic else 0.5 * (NY - 1) * DY
    at_turbine = DT * np.arange(NT) - init_x / U  # slice k reaches the turbine at k dt - InitX / U
    speed, turn, extra = np.full(NT, U), np.zeros(NT), np.zeros((NT, NY, NZ))
    if history:
        ht, hu, hd = (np.array(c) for c in zip(*HISTORY))
        speed, turn = np.interp(at_turbine, ht, hu), np.interp(at_turbine, ht, hd)
    if event is not None:  # IEC directions are clockwise seen from above: the turn is minus it
        e, D = event.at(at_turbine), event.rotor_diameter_m
        turn = turn - e["direction_deg"]
        extra = (e["gust_m_s"][:, None, None] + e["vshear_m_s"][:, None, None] * (heights - HUB)[None, None, :] / D
                 + e["hshear_m_s"][:, None, None] * y_nodes[None, :, None] / D)
    a = np.deg2rad(angle[None, None, :] + turn[:, None, None])
    ut = f["u"] + speed[:, None, None] * ratio[None, None, :] + extra
    nodes = np.stack([ut * np.cos(a) - f["v"] * np.sin(a), ut * np.sin(a) + f["v"] * np.cos(a), f["w"]], axis=-1)
    t, x, y, z = t_x_y_z.T
    ft = (t + (init_x - x) / U) / DT
    if periodic:
        ft = np.mod(ft, NT)
    fy, fz = (y + 0.5 * (NY - 1) * DY) / DY, (z - heights[0]) / DZ
    out = np.zeros((len(t), 3))
    for i in range(len(t)):
        k0, j0, m0 = (min(int(math.floor(v)), n - 2) for v, n in ((ft[i], NT + 1), (fy[i], NY), (fz[i], NZ)))
        wt, wy, wz = ft[i] - k0, fy[i] - j0, fz[i] - m0
        for dk, dj, dm in np.ndindex(2, 2, 2):
            w = (wt if dk else 1 - wt) * (wy if dj else 1 - wy) * (wz if dm else 1 - wz)
            out[i] += w * nodes[(k0 + dk) % NT, j0 + dj, m0 + dm]
    return out


def quantum(fmt: str, root: Path) -> np.ndarray:
    """The file's own resolution per component [m/s]: the int16 step (bts: 1/slope; wnd: U 1e-5 TI%), or float32's
    relative resolution 2^-23 times the largest speed in the HAWC boxes."""
    if fmt == "bts":
        head = struct.unpack("<h4i6f6fi", root.with_suffix(".bts").read_bytes()[:70])
        return np.array([1.0 / head[11], 1.0 / head[13], 1.0 / head[15]])
    if fmt == "wnd":
        head = struct.unpack("<hhi6f3fi4f4i", Path(f"{root}.wnd").read_bytes()[:80])
        return head[13] * 1e-5 * np.array(head[6:9])
    big = max(float(np.abs(np.fromfile(f"{root}_{c}.bin", "<f4")).max()) for c in "uvw") + U
    return np.full(3, big * 2.0**-23)


def run_driver(folder: Path, ifw_dat: Path, t_end_s: float, dt_s: float = 0.1, points=POINTS) -> np.ndarray:
    """Run the driver on ``ifw_dat`` at ``points`` for t = 0, dt, ..., t_end; (N, 7) rows T X Y Z U V W."""
    (folder / "points.txt").write_text("# X Y Z\n" + "".join(f"{x} {y} {z}\n" for x, y, z in points))
    steps = int(round(t_end_s / dt_s))
    (folder / "driver.inp").write_text("\n".join([
        "turbgen export check", "InflowWind driver input file.", "   f  Echo", "=" * 40,
        f'"{os.path.relpath(ifw_dat, folder)}"  IfWFileName', "=" * 40,
        " f WrHAWC", " f WrBladed", " f WrVTK", " f WrUniform", "=" * 40,
        f" {steps} NumTSteps", " 0.0 TStart", f" {dt_s} DT", " f Summary", " f SummaryFile", " f BoxExceedAllow",
        "-" * 40, " t PointsFile", ' "points.txt" PointsFileName', " f CalcAccel", "-" * 40,
        " f WindGrid", " 0,0,40 GridCtrCoord", " 1,1,0 GridDx", " 1,1,0 GridNx", "-" * 40,
        " 0 NOutWindXY", " 90 OutWindZ", " 0 NOutWindXZ", " 0 OutWindY", " 0 NOutWindYZ", " 0 OutWindX",
        "END of driver input file", ""]))
    done = subprocess.run([DRIVER, "driver.inp"], cwd=folder, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    rows = []
    for line in (folder / "points.Velocity.dat").read_text().splitlines():
        try:
            values = [float(v) for v in line.split()]
        except ValueError:
            continue
        if len(values) == 7:
            rows.append(values)
    out = np.array(rows)
    assert len(out) == (steps + 1) * len(points)
    return out


CASES = [  # (format, periodic, profile ("table": with a direction column), veer [deg/m], hub history, record
    # length [s] the driver samples)
    ("bts", True, "power:0.14", -0.4, False, 20.0),
    ("bts", False, "log:z0=0.05,d=5", 0.3, False, 13.0),
    ("bts", True, "table", 0.0, False, 20.0),
    ("bts", False, "power:0.2", -0.4, True, 13.0),
    ("wnd", True, "power:0.2", 0.0, False, 20.0),
    ("wnd", False, "log:z0=0.05,d=5", -0.4, False, 13.0),
    ("wnd", True, "table", 0.0, False, 20.0),
    ("wnd", True, "log:z0=0.05,d=5", 0.0, True, 20.0),
    ("hawc2", True, "log:z0=0.05,d=5", -0.4, False, 20.0),
    ("hawc2", True, "power:0.2", 0.0, False, 20.0),
    ("hawc2", True, "table", 0.0, False, 20.0),
    ("hawc2", True, "power:0.2", 0.2, True, 20.0),
]


@pytest.mark.parametrize("fmt, periodic, profile, veer, history, t_end_s", CASES,
                         ids=[f"{c[0]}-{'per' if c[1] else 'noper'}-{c[2].split(':')[0]}-veer{c[3]:g}"
                              f"{'-history' if c[4] else ''}" for c in CASES])
def test_driver_reads_the_store_plus_mean_wind(store, tmp_path, fmt, periodic, profile, veer, history, t_end_s):
    path, table, history_csv = store
    suffix = ".bts" if fmt == "bts" else ""
    root = tmp_path / "wind" / f"case{suffix}"
    root.parent.mkdir()
    args = ["export", str(path), "--format", fmt, "--out", str(root), "--runner-files",
            "--profile", f"table:{table}" if profile == "table" else profile]
    args += [] if not veer else ["--veer", str(veer)]
    args += [] if periodic else ["--no-periodic"]
    args += ["--mean-history", str(history_csv)] if history else []
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    stem = root.with_suffix("") if fmt == "bts" else root
    ifw_dat = stem.with_name(f"{stem.name}_InflowWind_{fmt}.dat")
    got = run_driver(tmp_path, ifw_dat, t_end_s)
    want = expected(path, profile, veer, history, periodic, got[:, :4])
    err = np.abs(got[:, 4:] - want).max(axis=0)
    # bound: half the file's resolution (the reader interpolates stored values, each within half a step of the
    # exact node value, with weights summing to 1) plus the reader's single-precision arithmetic (ReKi, float32:
    # a few roundings of 2^-24 |v|) and the F16.8 print (5e-9)
    tol = 0.5 * quantum(fmt, stem) + 8 * 2.0**-24 * np.abs(want).max(axis=0) + 1e-8
    print(f"\n{fmt} periodic={periodic} {profile} veer={veer:g} history={history}: max |error| u, v, w = "
          f"{err[0]:.2e}, {err[1]:.2e}, {err[2]:.2e} m/s (bound {tol[0]:.1e}, {tol[1]:.1e}, {tol[2]:.1e})")
    assert np.all(err <= tol), (err, tol)


# points for the uniform-wind transients: the hub, across the rotor (D = 80 m) left, right, above and below
UNIFORM_POINTS = [(0.0, 0.0, 90.0), (0.0, 35.0, 90.0), (0.0, -35.0, 70.0), (0.0, 10.0, 125.0), (0.0, -20.0, 55.0)]


@pytest.mark.parametrize("kind, sign", [("eog", "+"), ("edc", "-"), ("ecd", "+"), ("ews-v", "+"), ("ews-h", "-")])
def test_driver_reads_the_uniform_transients(tmp_path, kind, sign):
    from turbgen.spec.iec_transient import IecTransient

    hub, D, V = 90.0, 80.0, 12.0
    args = ["transient", kind, "--iec-class", "IIB", "--U", str(V), "--hub-height", str(hub),
            "--rotor-diameter", str(D), "--start", "2", "--duration", "30", "--sign", sign, "--out", str(tmp_path / "wind" / "event.hh")]
    (tmp_path / "wind").mkdir()
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    got = run_driver(tmp_path, tmp_path / "wind" / "event_InflowWind_uniform.dat", 20.0, 0.05, UNIFORM_POINTS)
    # the standard's formulas (IEC 61400-1 Ed. 4 Sect. 6.3.3) at the driver's times, which are rows of the file
    ev = IecTransient(kind.upper(), "IIB", V, hub, D, start_s=2.0, duration_s=30.0, sign=1 if sign == "+" else -1)
    t, y, z = got[:, 0], got[:, 2], got[:, 3]
    e = ev.at(t)
    speed = V * (z / hub) ** 0.2 + e["gust_m_s"] + e["vshear_m_s"] * (z - hub) / D + e["hshear_m_s"] * y / D
    delta = np.deg2rad(e["direction_deg"])  # clockwise seen from above, as InflowWind's WindDir
    want = np.column_stack([speed * np.cos(delta), -speed * np.sin(delta), np.zeros_like(t)])
    err = np.abs(got[:, 4:] - want).max(axis=0)
    # bound: the file's 10 significant digits (5e-10 relative, of speeds < 40 m/s) and the driver's F16.8 print
    print(f"\nuniform {kind.upper()} sign {sign}: max |error| u, v, w = {err[0]:.2e}, {err[1]:.2e}, {err[2]:.2e} m/s")
    assert np.all(err <= 1e-8 + 40 * 5e-10), err
    assert np.ptp(got[:, 4]) > 1.0 or np.ptp(got[:, 5]) > 1.0  # the event is in the record the driver read


# below the grid (bottom row 26 m): tower points at 26, 22, ..., 2 m; y is ignored there; below 2 m linear to 0
TOWER_POINTS = [(0.0, 0.0, 24.0), (0.0, 3.0, 13.0), (-5.0, 0.0, 7.5), (6.0, -2.0, 1.0)]


def test_driver_reads_the_tower_points(store, tmp_path):
    path, _, _ = store
    out = tmp_path / "wind" / "tower.bts"
    out.parent.mkdir()
    res = CliRunner().invoke(cli, ["export", str(path), "--format", "bts", "--out", str(out), "--tower",
                                   "--profile", "log:z0=0.05", "--veer", "-0.2"])
    assert res.exit_code == 0, res.output
    got = run_driver(tmp_path, out.with_name("tower_InflowWind_bts.dat"), 20.0, 0.1, TOWER_POINTS)
    # the tower column: the lowest row's fluctuations at y = 0 (mean of the two middle columns, ny even) plus the mean
    # wind at each tower height, turned by the veer there
    fs = open_store(path)
    heights = 26.0 - DZ * np.arange(7)
    f = {c: 0.5 * (fs.read_plane(c, 0)[:, NY // 2 - 1, 0] + fs.read_plane(c, 0)[:, NY // 2, 0]).astype(float)
         for c in "uvw"}
    ratio, angle = profile_and_veer("log:z0=0.05,d=0", -0.2, heights)
    a = np.deg2rad(angle)[None, :]
    ut = f["u"][:, None] + U * ratio[None, :]
    vt = np.repeat(f["v"][:, None], 7, axis=1)
    nodes = np.stack([ut * np.cos(a) - vt * np.sin(a), ut * np.sin(a) + vt * np.cos(a),
                      np.repeat(f["w"][:, None], 7, axis=1)], axis=-1)  # (nt, ntwr, 3)
    want = np.zeros((len(got), 3))
    for i, (t, x, _, z) in enumerate(got[:, :4]):
        ft = np.mod((t - x / U) / DT, NT)
        k0 = int(math.floor(ft))
        wt = ft - k0
        at_time = (1 - wt) * nodes[k0 % NT] + wt * nodes[(k0 + 1) % NT]  # (ntwr, 3)
        if z < heights[-1]:
            want[i] = at_time[-1] * z / heights[-1]  # linear to 0 at the ground
        else:
            j = min(int((heights[0] - z) // DZ), 5)
            wz = (heights[j] - z) / DZ
            want[i] = (1 - wz) * at_time[j] + wz * at_time[j + 1]
    err = np.abs(got[:, 4:] - want).max(axis=0)
    tol = 0.5 * quantum("bts", out.with_suffix("")) + 8 * 2.0**-24 * np.abs(want).max(axis=0) + 1e-8
    print(f"\nbts tower points, log law + veer: max |error| u, v, w = {err[0]:.2e}, {err[1]:.2e}, {err[2]:.2e} m/s "
          f"(bound {tol[0]:.1e}, {tol[1]:.1e}, {tol[2]:.1e})")
    assert np.all(err <= tol), (err, tol)


@pytest.mark.parametrize("fmt, kind, sign", [("bts", "ECD", "+"), ("hawc2", "EWS-H", "-"), ("wnd", "EWS-V", "+")])
def test_driver_reads_a_superimposed_transient(store, tmp_path, fmt, kind, sign):
    from turbgen.spec.iec_transient import IecTransient

    path, _, _ = store
    suffix = ".bts" if fmt == "bts" else ""
    root = tmp_path / "wind" / f"event{suffix}"
    root.parent.mkdir()
    res = CliRunner().invoke(cli, ["export", str(path), "--format", fmt, "--out", str(root), "--transient", kind,
                                   "--iec-class", "IIB", "--rotor-diameter", "24", "--transient-start", "3",
                                   "--transient-sign", sign, "--profile", "power:0.14"])
    assert res.exit_code == 0, res.output
    stem = root.with_suffix("") if fmt == "bts" else root
    got = run_driver(tmp_path, stem.with_name(f"{stem.name}_InflowWind_{fmt}.dat"), 20.0)
    event = IecTransient(kind, "IIB", U, HUB, 24.0, start_s=3.0, duration_s=(NT - 1) * DT, sign=1 if sign == "+" else -1)
    want = expected(path, "power:0.14", 0.0, False, True, got[:, :4], event)
    err = np.abs(got[:, 4:] - want).max(axis=0)
    tol = 0.5 * quantum(fmt, stem) + 8 * 2.0**-24 * np.abs(want).max(axis=0) + 1e-8
    print(f"\n{fmt} + {kind} ({sign}): max |error| u, v, w = {err[0]:.2e}, {err[1]:.2e}, {err[2]:.2e} m/s "
          f"(bound {tol[0]:.1e}, {tol[1]:.1e}, {tol[2]:.1e})")
    assert np.all(err <= tol), (err, tol)
