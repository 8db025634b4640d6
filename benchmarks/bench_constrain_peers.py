"""Constrained-field benchmark against the peers: turbgen, pyconturb, hipersim and mannrs 2.x on the same point data.

    python benchmarks/bench_constrain_peers.py             # frozen 3D box 1024 x 32 x 32 at 5 m, N = 50, 200, 500
    python benchmarks/bench_constrain_peers.py --quick     # 128 x 12 x 12, N = 20, to check the script
    python benchmarks/bench_constrain_peers.py --n 50 --tools turbgen,mannrs --grid 1024,16,16 --timeout 300

Needs the `bench` extra (pip install pyconturb hipersim mannrs).

The data: the u component of a frozen turbgen Mann field (seed 1; `turbgen mann --evo frozen --planes 0`, U 10 m/s,
dt 0.5 s so dx = U dt = 5 m, dy = dz = 5 m, L 30 m, Gamma 3.1) at N points: 10 "masts" at fixed (y, z) grid nodes,
each sampled at N / 10 equally spaced times (x = U t), every point a grid node. The same N values go to every tool
as far as its API allows:

  turbgen    u at the N points: one point-series file, a sensor per mast whose series is missing (null) except at
             its N / 10 sampled times (`turbgen mann ... --constrain FILE`, zero noise; the gaps make it a
             conjugate-gradient solve);
  mannrs     `Constraint(x, y, z, u)` at the N points (u only is its API); default corr_thres 1e-4 and
             spectral_compression_target 0.8;
  hipersim   `constrain_field` rows (x, y, z, u, v, w) at the N points: its API conditions u, v and w together,
             so it also gets the truth's v and w there (3N values, a superset); its own unconstrained base field
             (generate_field, seed 2);
  pyconturb  `gen_turb(con_tc=TimeConstraint)` takes whole series only (no gaps: it FFTs them), so it gets the
             full u series (all nt samples) of the 10 masts, a superset of the N values; it simulates u on the
             32 x 32 plane.

What each models differs: turbgen, hipersim and mannrs condition a Mann (1994) prior with the same L, Gamma and
alpha*eps^(2/3) (each its own discretisation); pyconturb a Kaimal spectrum with IEC exponential coherence (sigma_u
set to the truth's) on a frozen plane. The comparison is therefore of the *conditioning machinery* (time, memory,
how well the data are reproduced), not of identical priors. Each tool runs in its own subprocess (peak RSS of that
process, ru_maxrss, printed by the child), with a timeout. Reported: wall time, peak RSS, the largest |field - data|
over the N points (u), and a failure (exception, e.g. singular matrix) or timeout.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
import traceback

import numpy as np

U_M_S, DT_S, D_M, L_M, GAMMA, AE = 10.0, 0.5, 5.0, 30.0, 3.1, 0.05  # ae = alpha*eps^(2/3) [m^(4/3)/s^2]
HUB_M = 150.0
N_MASTS = 10
TOOLS = ("turbgen", "mannrs", "hipersim", "pyconturb")


def _grid_args(case: dict) -> list[str]:
    return ["--evo", "frozen", "--planes", "0", "--U", str(U_M_S), "--dt", str(DT_S), "--nt", str(case["nt"]),
            "--ny", str(case["ny"]), "--nz", str(case["nz"]), "--dy", str(D_M), "--L", str(L_M), "--gamma",
            str(GAMMA), "--ae", str(AE), "--hub-height", str(HUB_M)]  # fmt: skip


def _run_turbgen(case: dict, d: str) -> np.ndarray:
    """`turbgen mann --constrain` on a point-series file holding the N values; returns u at the points."""
    from turbgen.cli import main
    from turbgen.store import open_store

    pts = np.array(case["points"])  # rows (it, iy, iz)
    t = np.arange(case["nt"]) * DT_S
    sensors = []
    for m, (iy, iz) in enumerate(case["masts"]):
        series = [None] * case["nt"]
        for (it, py, pz), u in zip(pts, case["u"]):
            if (py, pz) == (iy, iz):
                series[it] = u
        sensors.append({"name": f"mast{m}", "x_m": 0.0, "y_m": case["y_m"][iy], "z_m": case["z_m"][iz],
                        "u_m_s": series})  # fmt: skip
    path = os.path.join(d, "points.json")
    with open(path, "w") as f:
        json.dump({"kind": "point-series", "name": "bench points", "time_s": t.tolist(), "sensors": sensors}, f)
    out = os.path.join(d, "turbgen.zarr")
    sys.argv = ["turbgen", "mann", *_grid_args(case), "--seed", "2", "--threads", "2", "--constrain", path,
                "--out", out]  # fmt: skip
    try:
        main()
    except SystemExit as exc:
        if exc.code:
            raise RuntimeError(f"turbgen exited with {exc.code}") from None
    fs = open_store(out)
    u, solver = fs.read_plane("u", 0), fs.attrs["constraints"]["solver"]
    return u[pts[:, 0], pts[:, 1], pts[:, 2]], {"solver": f"{solver['method']} {solver['iterations']} it."}


def _run_mannrs(case: dict, d: str) -> np.ndarray:
    import mannrs

    nx, ny, nz = case["nt"], case["ny"], case["nz"]
    # mannrs' axes are linspace(0, L, N): L = (N - 1) spacing puts the nodes at i * spacing
    stencil = mannrs.Stencil(L=L_M, gamma=GAMMA, Lx=(nx - 1) * D_M, Ly=(ny - 1) * D_M, Lz=(nz - 1) * D_M,
                             Nx=nx, Ny=ny, Nz=nz)  # fmt: skip
    pts = np.array(case["points"])
    cons = [mannrs.Constraint(x=float(it * D_M), y=float(iy * D_M), z=float(iz * D_M), u=float(u))
            for (it, iy, iz), u in zip(pts, case["u"])]  # fmt: skip
    wf = stencil.constrain(cons).build(parallel=True).turbulence(AE, 2, parallel=True)
    return wf.U[pts[:, 0], pts[:, 1], pts[:, 2]]


def _run_hipersim(case: dict, d: str) -> np.ndarray:
    from hipersim.turbgen.constrain_field import constrain_field

    pts = np.array(case["points"])
    rows = np.column_stack([pts * D_M, case["u"], case["v"], case["w"]])
    with contextlib.redirect_stdout(io.StringIO()):  # it prints its progress
        u, _, _ = constrain_field(rows, alphaepsilon=AE, L=L_M, Gamma=GAMMA, Nx=case["nt"], Ny=case["ny"],
                                  Nz=case["nz"], dx=D_M, dy=D_M, dz=D_M, TurbOptions={"SeedNo": 2})  # fmt: skip
    return u[pts[:, 0], pts[:, 1], pts[:, 2]]


def _run_pyconturb(case: dict, d: str) -> np.ndarray:
    import pandas as pd
    from pyconturb import TimeConstraint, gen_spat_grid, gen_turb
    from pyconturb.sig_models import constant_sig
    from pyconturb.wind_profiles import constant_profile

    nt, y, z = case["nt"], np.array(case["y_m"]), HUB_M + np.array(case["z_m"])
    spat = gen_spat_grid(y, z, comps=[0])
    t = np.arange(nt) * DT_S
    cols = {f"mast{m}": [0.0, 0.0, y[iy], z[iz], *(U_M_S + np.array(case["mast_u"][m]))]
            for m, (iy, iz) in enumerate(case["masts"])}  # fmt: skip
    con = TimeConstraint(pd.DataFrame(cols, index=["k", "x", "y", "z", *t]))
    turb = gen_turb(spat, T=nt * DT_S, nt=nt, con_tc=con, wsp_func=constant_profile, sig_func=constant_sig,
                    u_ref=U_M_S, z_ref=HUB_M, sig_vals=[case["sigma_u"]], comps=[0], seed=2)  # fmt: skip
    u = turb.values - U_M_S  # (nt, ny * nz), column iy * nz + iz (gen_spat_grid's order)
    full = np.array([u[:, iy * case["nz"] + iz] for iy, iz in case["masts"]])
    err = np.abs(full - np.array(case["mast_u"]))
    # gen_turb drops the data's mean (frequency 0) and adds its wind profile instead: the error minus each
    # series' own mean shows what the conditioning reproduces
    demeaned = np.abs(full - full.mean(1, keepdims=True)
                                 - (np.array(case["mast_u"]) - np.mean(case["mast_u"], axis=1, keepdims=True)))
    extra = {"full_series_max_err": float(err.max()), "full_series_max_err_minus_mean": float(demeaned.max())}
    pts = np.array(case["points"])
    return u[pts[:, 0], pts[:, 1] * case["nz"] + pts[:, 2]], extra


def _child(tool: str, case_path: str, out_path: str) -> None:
    """Run one tool on one case in this process; write its result (time, peak RSS, errors) to out_path."""
    with open(case_path) as f:
        case = json.load(f)
    t0 = time.perf_counter()
    res: dict = {"tool": tool}
    try:
        with tempfile.TemporaryDirectory(dir=os.path.dirname(out_path)) as d:
            got = globals()[f"_run_{tool}"](case, d)
        if isinstance(got, tuple):  # (values, extra metrics)
            got, extra = got
            res.update(extra)
        err = np.abs(np.asarray(got, dtype=float) - np.array(case["u"]))
        res.update(max_err=float(err.max()), rms_err=float(np.sqrt(np.mean(err**2))))
    except Exception as exc:  # a peer's failure (e.g. LinAlgError) is a result, not a crash of the benchmark
        res["error"] = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"[:120]
        traceback.print_exc()
    res["time_s"] = time.perf_counter() - t0
    res["peak_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    with open(out_path, "w") as f:
        json.dump(res, f)


def _spawn(tool: str, case_path: str, d: str, timeout_s: float) -> dict:
    out = os.path.join(d, f"{tool}.result.json")
    # turbgen's command sets OPENBLAS_NUM_THREADS=1 before numpy loads (its own thread pools); the child imports
    # numpy first, so set it here as the command would. The peers keep OpenBLAS' default (all cores).
    env = os.environ | ({"OPENBLAS_NUM_THREADS": "1"} if tool == "turbgen" else {})
    t0 = time.perf_counter()
    try:
        subprocess.run([sys.executable, __file__, "--child", tool, case_path, out], timeout=timeout_s, env=env,
                       stdout=subprocess.DEVNULL, stderr=open(os.path.join(d, f"{tool}.log"), "w"))  # fmt: skip
    except subprocess.TimeoutExpired:
        return {"tool": tool, "error": f"timeout ({timeout_s:.0f} s)", "wall_s": time.perf_counter() - t0}
    wall = time.perf_counter() - t0
    if not os.path.exists(out):
        return {"tool": tool, "error": "crashed (see log)", "wall_s": wall}
    with open(out) as f:
        res = json.load(f)
    res["wall_s"] = wall
    return res


def _truth(grid: dict, d: str) -> dict:
    """The frozen turbgen field of seed 1 (the 'measured' wind): u, v, w (nt, ny, nz) at plane 0."""
    from turbgen.store import open_store

    out = os.path.join(d, "truth.zarr")
    subprocess.run([sys.executable, "-c", "from turbgen.cli import main; main()", "mann", *_grid_args(grid),
                    "--seed", "1", "--out", out], check=True, stdout=subprocess.DEVNULL)  # fmt: skip
    fs = open_store(out)
    return {c: fs.read_plane(c, 0).astype(float) for c in "uvw"} | {"y": fs.grid.y(), "z": fs.grid.z()}


def _case(grid: dict, truth: dict, n: int) -> dict:
    """N = 10 masts x N/10 samples: masts on a ring of grid nodes, samples equally spaced in time."""
    nt, ny, nz = grid["nt"], grid["ny"], grid["nz"]
    ang = 2 * np.pi * np.arange(N_MASTS) / N_MASTS
    masts = [(int(round((ny - 1) * (0.5 + 0.35 * np.cos(a)))), int(round((nz - 1) * (0.5 + 0.35 * np.sin(a)))))
             for a in ang]  # fmt: skip
    if len(set(masts)) < N_MASTS:
        raise SystemExit(f"the {ny} x {nz} plane is too small for {N_MASTS} distinct masts")
    per = n // N_MASTS
    points = [(int((k * nt) // per + m) % nt, iy, iz) for m, (iy, iz) in enumerate(masts) for k in range(per)]
    p = np.array(points)
    return {**grid, "masts": masts, "points": points, "y_m": truth["y"].tolist(), "z_m": truth["z"].tolist(),
            "u": truth["u"][p[:, 0], p[:, 1], p[:, 2]].tolist(), "v": truth["v"][p[:, 0], p[:, 1], p[:, 2]].tolist(),
            "w": truth["w"][p[:, 0], p[:, 1], p[:, 2]].tolist(),
            "mast_u": [truth["u"][:, iy, iz].tolist() for iy, iz in masts],
            "sigma_u": float(truth["u"].std())}  # fmt: skip


def _fmt(r: dict) -> str:
    t = f"{r.get('time_s', r['wall_s']):7.1f} s"
    mem = f"{r['peak_mib']:6.0f} MiB" if "peak_mib" in r else "      -    "
    if "max_err" in r:
        full = ("" if "full_series_max_err" not in r else f"; full series: max {r['full_series_max_err']:.1e}, "
                f"minus the series' mean {r['full_series_max_err_minus_mean']:.1e}")
        solver = f"; {r['solver']}" if "solver" in r else ""
        return f"{t}  {mem}  max {r['max_err']:.1e}  rms {r['rms_err']:.1e} m/s{full}{solver}"
    return f"{t}  {mem}  FAILED: {r['error']}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="128 x 12 x 12, N = 20")
    ap.add_argument("--n", default=None, help="comma-separated N (default 50,200,500)")
    ap.add_argument("--grid", default=None, help="NT,NY,NZ of the box (default 1024,32,32)")
    ap.add_argument("--tools", default=",".join(TOOLS))
    ap.add_argument("--timeout", type=float, default=600.0, help="per tool and case [s]")
    ap.add_argument("--child", nargs=3, metavar=("TOOL", "CASE", "OUT"), help=argparse.SUPPRESS)
    opt = ap.parse_args()
    if opt.child:
        _child(*opt.child)
        return
    sizes = opt.grid or ("128,12,12" if opt.quick else "1024,32,32")
    grid = dict(zip(("nt", "ny", "nz"), (int(v) for v in sizes.split(","))))
    ns = [int(v) for v in (opt.n or ("20" if opt.quick else "50,200,500")).split(",")]
    tools = [t for t in opt.tools.split(",") if t]
    print(f"load average {os.getloadavg()}  grid {grid['nt']} x {grid['ny']} x {grid['nz']} at {D_M} m, "
          f"Mann L {L_M} m, Gamma {GAMMA}, ae {AE}; pyconturb: Kaimal + IEC coherence (different prior)", flush=True)
    with tempfile.TemporaryDirectory(dir=".") as d:
        truth = _truth(grid, d)
        for n in ns:
            case_path = os.path.join(d, f"case{n}.json")
            with open(case_path, "w") as f:
                json.dump(_case(grid, truth, n), f)
            for tool in tools:
                if tool == "pyconturb" and n != ns[0]:
                    print(f"N={n:4d}  pyconturb not rerun: its constraints (the 10 masts' full series) are those of "
                          f"N={ns[0]}")  # fmt: skip
                    continue
                r = _spawn(tool, case_path, d, opt.timeout)
                print(f"N={n:4d}  {tool:9s} wall {r['wall_s']:7.1f} s | {_fmt(r)}", flush=True)
                log = os.path.join(d, f"{tool}.log")
                if "error" in r and os.path.exists(log) and (tail := "".join(open(log).readlines()[-3:]).strip()):
                    print("   " + tail.replace("\n", "\n   "))
    print(f"load average {os.getloadavg()}")


if __name__ == "__main__":
    main()
