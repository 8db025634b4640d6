"""Total-wind constraint data are turned into fluctuations by the exports' own mean wind (one definition): a field
conditioned on total (u, v, w) under a log law, veer and a hub history, exported with that mean wind, gives back the
data at the sensors; the file's mean_wind is refused where it makes no sense."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from turbgen.errors import ParameterError
from turbgen.exporters import ExportRequest, export_store, read_hawc2
from turbgen.runs.constrain import describe_constraints, run_mann_constrained
from turbgen.spec.constraints import load_point_series, point_series_from_mapping
from turbgen.spec.mann import MannRun
from turbgen.spec.mean_wind import MeanWind
from turbgen.store import open_store

U, HUB, DT = 16.0, 150.0, 0.5
GRID = {"nt": 128, "dt_s": DT, "x_m": [0.0, 40.0], "ny": 4, "nz": 4, "dy_m": 10.0}  # z nodes -15, -5, 5, 15 m
Z0, VEER = 0.03, -0.3  # log law roughness [m], veer [deg/m]
HISTORY = [(5.0, 15.0, 0.0), (30.0, 17.5, 6.0), (55.0, 16.0, -3.0)]  # t [s], U [m/s], direction [deg]


def total_wind(t_stored, y, height, u_f, v_f):
    """Total (u, v) from the formulas: U_hub(t) ln(h/z0)/ln(hub/z0) + u', then turned counter-clockwise (seen from
    above) by VEER (h - hub) + direction(t) (Jonkman 2009, TurbSim's log profile and per-height rotation)."""
    ht, hu, hd = (np.array(c) for c in zip(*HISTORY))
    speed = np.interp(t_stored, ht, hu) * math.log(height / Z0) / math.log(HUB / Z0) + u_f
    a = np.deg2rad(VEER * (height - HUB) + np.interp(t_stored, ht, hd))
    return speed * np.cos(a) - v_f * np.sin(a), speed * np.sin(a) + v_f * np.cos(a)


def constraint_file(folder, total=True, mean_wind=True, components="uvw"):
    """Two sensors on grid nodes (the rotor plane at 155 m, the x = 40 m plane at 135 m), sampled at stored grid
    times, with total u, v (and w, a fluctuation) of the formulas above."""
    (folder / "hub.csv").write_text("t, U, direction\n" + "".join(f"{t},{u},{d}\n" for t, u, d in HISTORY))
    sensors = []
    for name, x, y, height in (("rotor", 0.0, 5.0, 155.0), ("upstream", 40.0, -15.0, 135.0)):
        t = np.arange(0.0, 60.0, DT)  # physical time; stored time t + x / U is a grid time (x / U = 2.5 s)
        u_f, v_f, w = 1.5 * np.sin(t / 3.0 + x), 0.8 * np.cos(t / 4.0), 0.4 * np.sin(t / 2.0)
        u, v = total_wind(t + x / U, y, height, u_f, v_f)
        series = {"u_m_s": list(u), "v_m_s": list(v), "w_m_s": list(w)}
        sensors.append({"name": name, "x_m": x, "y_m": y, "height_m": height,
                        **{f"{c}_m_s": series[f"{c}_m_s"] for c in components}})
    data = {"kind": "point-series", "name": "mast", "time_s": list(np.arange(0.0, 60.0, DT)), "total_wind": total,
            "sensors": sensors}
    if mean_wind:
        data["mean_wind"] = {"profile": f"log:z0={Z0}", "veer_deg_per_m": VEER, "mean_history": "hub.csv"}
    (folder / "mast.json").write_text(json.dumps(data))
    return folder / "mast.json", data


def test_constrained_field_exported_with_the_mean_wind_gives_back_the_total_wind(tmp_path):
    path, data = constraint_file(tmp_path)
    run = MannRun.from_mapping({"seed": 4, "U_m_s": U, "hub_height_m": HUB, "grid": GRID})
    series = load_point_series(path)  # the history's file is found beside the constraint file
    run_mann_constrained(run, tmp_path / "c.zarr", [series], threads=1)
    lines = describe_constraints(open_store(tmp_path / "c.zarr").attrs["constraints"])
    assert lines[-1].startswith("total-wind data: mean wind removed: log law z0 = 0.03 m, d = 0 m; veer -0.3 deg/m; "
                                "hub history hub.csv (3 points)")
    ht, hu, hd = zip(*HISTORY)
    wind = MeanWind(profile="log", roughness_m=Z0, veer_deg_per_m=VEER, history_times_s=ht, history_speeds_m_s=hu,
                    history_directions_deg=hd)
    y_nodes, z_nodes = [-15.0, -5.0, 5.0, 15.0], [-15.0, -5.0, 5.0, 15.0]
    for plane, sensor in enumerate(data["sensors"]):
        export_store(tmp_path / "c.zarr", "hawc2", tmp_path / f"p{plane}",
                     ExportRequest(plane=plane, mean_wind=wind))
        box = read_hawc2(tmp_path / f"p{plane}", (GRID["nt"], 4, 4), U)
        iy, iz = y_nodes.index(sensor["y_m"]), z_nodes.index(sensor["height_m"] - HUB)
        k = np.round((np.array(data["time_s"]) + sensor["x_m"] / U) / DT).astype(int)  # stored time steps
        inside = k < GRID["nt"]
        assert inside.sum() > 100
        for c in "uvw":
            got = box[c][k[inside], iy, iz]
            want = np.array(sensor[f"{c}_m_s"])[inside]
            # zero noise: the field passes through the data to float32 round-off (~1e-6 m/s of the store and the
            # HAWC file); 1e-4 m/s is the bound the constraint tests use
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-4)


def test_default_mean_wind_is_the_exports_power_law(tmp_path):
    path, data = constraint_file(tmp_path, mean_wind=False, components="uw")
    f = load_point_series(path)
    assert f.mean_wind == MeanWind()  # power law, alpha 0.2: what `turbgen export` adds by default


@pytest.mark.parametrize("change, message", [
    ({"total_wind": False}, "mean_wind describes total-wind data"),
    ({"mean_wind": {"profile": "log:z0=-1"}}, "log-law roughness z0 (m)"),
    ({"mean_wind": {"profile": "table:missing.csv"}}, "missing.csv: does not exist"),
    ({"mean_wind": {"veer_deg_per_m": 99}}, "veer (deg/m)"),
    ({"mean_wind": {"profile": "power:0.2", "shear": 1}}, "shear"),
])
def test_bad_mean_wind_is_refused(tmp_path, change, message):
    _, data = constraint_file(tmp_path)
    with pytest.raises(ParameterError, match=message.replace("(", r"\(").replace(")", r"\)")):
        point_series_from_mapping({**data, **change}, str(tmp_path / "mast.json"))


def test_turning_mean_wind_needs_u_and_v(tmp_path):
    path, _ = constraint_file(tmp_path, components="uw")
    run = MannRun.from_mapping({"seed": 4, "U_m_s": U, "hub_height_m": HUB, "grid": GRID})
    with pytest.raises(ParameterError, match="mixes u and v: give both"):
        run_mann_constrained(run, tmp_path / "c.zarr", [load_point_series(path)], threads=1)
    assert not (tmp_path / "c.zarr").exists()
