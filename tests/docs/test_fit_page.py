"""The Python examples of docs/fit.md run as written, from a directory holding the repository's examples/."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_fit_examples_run_as_written(run_example, tmp_path):
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "fit.md").read_text(), re.S)
    assert len(blocks) == 2 and "point_series" in blocks[1]
    printed = run_example("\n".join(blocks), "docs/fit.md")
    assert (tmp_path / "fit.png").read_bytes()[:4] == b"\x89PNG"
    first, table = printed.split("\n", 1)
    assert first.startswith(f"{float(first.split()[0])} (") and "length_scale_m" in table, printed
