"""`turbgen serve` without the `service` extra: one line naming the extra, exit 2, no traceback."""

from __future__ import annotations

import subprocess
import sys

import pytest

PROBE = """
import sys
sys.modules[{missing!r}] = None  # as if the extra were not installed: importing it raises ImportError
from turbgen.cli import main
sys.argv = ["turbgen", "serve", "--root", {root!r}]
main()
"""


@pytest.mark.parametrize("missing", ["fastapi", "uvicorn"])
def test_serve_without_the_service_extra_says_how_to_install_it(tmp_path, missing):
    res = subprocess.run([sys.executable, "-c", PROBE.format(missing=missing, root=str(tmp_path / "root"))],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert res.stderr.strip().splitlines() == [f'Error: turbgen serve needs {missing}: pip install "turbgen[service]"']
    assert not (tmp_path / "root").exists()
