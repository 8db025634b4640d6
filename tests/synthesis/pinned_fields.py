"""Small fields pinned across refactors: the CLI commands, the machine fingerprint and the arrays.

``python tests/synthesis/pinned_fields.py`` rewrites ``tests/synthesis/data/pinned_fields.npz``; do that only when a
change is *meant* to change the fields (and say so in the commit). ``test_pinned_fields.py`` reads it.
"""

from __future__ import annotations

import platform
import sys
import tempfile
from pathlib import Path

import numpy as np

PINNED = Path(__file__).with_name("data") / "pinned_fields.npz"
SMALL = ["--ny", "6", "--nz", "6", "--seed", "3"]
CASES = {
    "mann_default_ae": ["mann", "--nt", "64", "--planes", "0,50", *SMALL],
    "mann_stable_ti_mannlife": ["mann", "--preset", "stable", "--ti", "0.1", "--U", "9", "--nt", "64", "--dz", "3",
                                "--planes", "0,30,60", "--lifetime", "mann", *SMALL],
    "mann_sigma_u_frozen": ["mann", "--evo", "frozen", "--sigma-u", "1.5", "--nt", "64", "--planes", "0,20", *SMALL],
    "kaimal_default": ["kaimal", "--nt", "128", "--planes", "0,50", *SMALL],
    "kaimal_unstable_class_c": ["kaimal", "--preset", "unstable", "--nt", "128", "--dz", "5", "--planes", "0,25,50",
                                *SMALL],
}


def fingerprint() -> str:
    """What decides the last bits of a float32 field: numpy/scipy/pyfftw builds and whether the CPU has AVX2 and FMA.

    AVX-512 is not part of it: numpy's AVX-512 and AVX2 float32 kernels and OpenBLAS's SkylakeX and Haswell kernels
    gave the pinned fields bit for bit (an AVX-512 machine ran this suite), so such a machine checks the bits too;
    test_cpu_kernels runs every OpenBLAS kernel the machine offers."""
    import pyfftw
    import scipy

    flags = Path("/proc/cpuinfo").read_text().split("flags", 1)[-1].split("\n", 1)[0] if Path("/proc/cpuinfo").exists() else ""
    simd = ",".join(f for f in ("avx2", "fma") if f" {f}" in flags)
    return (f"{platform.machine()} numpy {np.__version__} scipy {scipy.__version__} pyfftw {pyfftw.__version__} "
            f"simd {simd}")


def make_field(name: str, directory: Path) -> dict[str, np.ndarray]:
    """Run the pinned command ``name`` through the CLI; u, v, w as (nx, nt, ny, nz) and the coordinates."""
    from click.testing import CliRunner

    from turbgen.cli import cli
    from turbgen.store import open_store

    out = directory / f"{name}.zarr"
    res = CliRunner().invoke(cli, [*CASES[name], "--out", str(out)])
    assert res.exit_code == 0, res.output
    fs = open_store(out)
    arrays = {c: np.stack([fs.read_plane(c, ix) for ix in range(fs.grid.nx)]) for c in "uvw"}
    arrays.update(t=fs.grid.t(), x=fs.grid.x(), y=fs.grid.y(), z=fs.grid.z())
    return arrays


def main() -> None:
    PINNED.parent.mkdir(exist_ok=True)
    data = {"fingerprint": np.array(fingerprint())}
    with tempfile.TemporaryDirectory() as tmp:
        for name in CASES:
            for key, value in make_field(name, Path(tmp)).items():
                data[f"{name}/{key}"] = value
    np.savez_compressed(PINNED, **data)
    print(f"wrote {PINNED} ({PINNED.stat().st_size} bytes) on {data['fingerprint']}", file=sys.stderr)


if __name__ == "__main__":
    main()
