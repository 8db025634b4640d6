"""docs/examples/quickstart.py runs, and what it writes is what the equivalent commands write, bit for bit."""

import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.exporters import read_bts
from turbgen.store import open_store

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "docs" / "examples" / "quickstart.py"


def _code_lines(path: Path) -> int:
    """Lines of user code: not blank, not a comment, not the module docstring."""
    text = path.read_text()
    body = text.split('"""', 2)[2] if text.startswith('"""') else text
    return sum(1 for line in body.splitlines() if line.strip() and not line.strip().startswith("#"))


def _same_store(a: Path, b: Path):
    fa, fb = open_store(a), open_store(b)
    assert fa.attrs["parameters"] == fb.attrs["parameters"] and fa.grid == fb.grid
    for c in ("u", "v", "w"):
        for ix in range(fa.grid.nx):
            np.testing.assert_array_equal(fa.read_plane(c, ix), fb.read_plane(c, ix))


def test_quickstart_matches_the_commands(tmp_path, run_example, monkeypatch):
    """The script run as ``python quickstart.py DIRECTORY``, in this process (run_example; the process itself is
    tests/cli/test_entry_point.py's subject)."""
    import matplotlib.pyplot as plt

    assert _code_lines(SCRIPT) <= 15
    monkeypatch.setattr(sys, "argv", [str(SCRIPT), str(tmp_path)])
    plt.close("all")  # the script draws on pyplot's current figure
    assert "all metrics pass" in run_example(SCRIPT.read_text(), str(SCRIPT))
    plt.close("all")
    assert (tmp_path / "spectrum_u.png").stat().st_size > 10_000
    cmds = tmp_path / "cli"
    cmds.mkdir()
    runner = CliRunner()
    for args in (["mann", "--L", "49", "--gamma", "3.1", "--evo", "400", "--nt", "512", "--ny", "16", "--nz", "16",
                  "--dy", "8", "--out", str(cmds / "mann_small.zarr")],
                 ["kaimal", "--U", "16", "--nt", "512", "--ny", "16", "--nz", "16", "--dy", "8", "--planes", "0,50,100",
                  "--out", str(cmds / "kaimal_small.zarr")],
                 ["export", str(cmds / "mann_small.zarr"), "--format", "bts", "--out", str(cmds / "mann_small.bts")]):
        r = runner.invoke(cli, args)
        assert r.exit_code == 0, r.output
    _same_store(tmp_path / "mann_small.zarr", cmds / "mann_small.zarr")
    _same_store(tmp_path / "kaimal_small.zarr", cmds / "kaimal_small.zarr")
    # the same bytes but for the description, which names the store's path
    api_bts, cli_bts = read_bts(tmp_path / "mann_small.bts"), read_bts(cmds / "mann_small.bts")
    api_text, cli_text = api_bts.pop("description"), cli_bts.pop("description")
    assert api_text.replace(str(tmp_path), str(cmds)) == cli_text
    assert api_bts.keys() == cli_bts.keys()
    for key, value in api_bts.items():
        np.testing.assert_array_equal(value, cli_bts[key], err_msg=key)
    sizes = [(tmp_path / "mann_small.bts").stat().st_size - len(api_text), (cmds / "mann_small.bts").stat().st_size - len(cli_text)]
    assert sizes[0] == sizes[1]


@pytest.mark.parametrize("page", ["README.md", "docs/getting-started.md"])
def test_first_python_example_runs(page, tmp_path, run_example):
    """The first Python example of the README and of Getting started (at most 10 lines of code after the imports)
    runs as written."""
    import re

    code = re.search(r"```python\n(.*?)```", (ROOT / page).read_text(), re.S).group(1)
    lines = [line for line in code.splitlines() if line.strip() and not line.startswith("import ")]
    assert len(lines) <= 10
    assert "all metrics pass" in run_example(code, page) and (tmp_path / "mann_small.bts").exists()  # validate, export


def test_api_guide_runs_as_written(tmp_path, run_example):
    """The Python blocks of docs/api.md (the notebook path), run in order in one process as written."""
    import re

    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "api.md").read_text(), re.S)
    assert len(blocks) >= 3
    printed = run_example("\n".join(blocks), "docs/api.md")
    assert "all metrics pass" in printed and "True [256, 11, 16, 16]" in printed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["field.bts", "field_InflowWind_bts.dat"]  # no store
