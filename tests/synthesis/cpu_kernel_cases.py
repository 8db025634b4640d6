"""What the CPU-kernel test (test_cpu_kernels.py) computes in a child process under one OpenBLAS core type:
``python cpu_kernel_cases.py OUT.npz DIR`` writes the pinned fields, a lidar-constrained field, whether its lidar
record placed from a CSV copy equals the dataset's to the bit, and the dependent-measurement refusal's message."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
sys.path[:0] = [str(HERE), str(HERE.parent / "constrain")]

from pinned_fields import CASES, make_field  # noqa: E402
from test_lidar_constraints import GRID, LIDAR  # noqa: E402
from test_los_csv import _write_csv  # noqa: E402
from test_run import SMALL, _mast, _write  # noqa: E402


def _cli(args: list) -> str:
    from click.testing import CliRunner

    from turbgen.cli import cli

    res = CliRunner().invoke(cli, [str(a) for a in args], prog_name="turbgen")
    return res.output if res.exit_code in (0, 1) else f"exit {res.exit_code}: {res.output}"


def lidar_case(d: Path) -> dict[str, np.ndarray]:
    """Truth -> virtual lidar dataset -> its CSV copy -> the field conditioned on the dataset (plane 2)."""
    from turbgen.virtual_lidar.dataset import read_dataset
    from turbgen.virtual_lidar.los_csv import read_los_csv
    from turbgen.runs.constrain import place
    from turbgen.spec.mann import MannRun
    from turbgen.store import open_store

    (d / "small.json").write_text(json.dumps(LIDAR))
    _cli(["mann", *GRID, "--seed", "1", "--out", d / "truth.zarr"])
    _cli(["lidar", "run", d / "truth.zarr", "--lidar", d / "small.json", "--rotor-radius", "10", "--mean-wind",
          "--out", d / "truth_lidar.zarr"])  # fmt: skip
    data = read_dataset(d / "truth_lidar.zarr")
    _write_csv(d / "los.csv", data.v_los, data.time_s)
    run = MannRun.from_mapping({"grid": {"nt": 256, "dt_s": 0.5, "x_m": [0.0, 20.0, 40.0], "ny": 8, "nz": 8,
                                         "dy_m": 5.0}})  # fmt: skip
    a, b = place(run, [data]), place(run, [read_los_csv(d / "los.csv")])
    same = np.array_equal(a.data, b.data, equal_nan=True) and all(
        np.array_equal(getattr(a.streams, k), getattr(b.streams, k)) for k in ("term_weight", "offset", "term_shift"))
    _cli(["mann", *GRID, "--seed", "2", "--constrain", d / "truth_lidar.zarr", "--out", d / "c.zarr"])
    fs = open_store(d / "c.zarr")
    out = {f"constrained/{c}": fs.read_plane(c, 2) for c in "uvw"}
    out["lidar/v_los"] = data.v_los
    out["csv_places_the_same_bits"] = np.array(same)
    return out


def refusal_message(d: Path) -> str:
    """The one line of ``turbgen mann`` conditioned twice on the same mast with zero noise."""
    path = _write(d / "m.json", _mast(np.arange(0.0, 20.0, 0.5)))
    return _cli(["mann", *SMALL, "--constrain", path, "--constrain", path, "--out", d / "r.zarr"])


def main(out: Path, d: Path) -> None:
    arrays = {}
    for name in CASES:
        for key, value in make_field(name, d).items():
            arrays[f"{name}/{key}"] = value
    arrays.update(lidar_case(d))
    arrays["refusal"] = np.array(refusal_message(d))
    np.savez(out, **arrays)


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
