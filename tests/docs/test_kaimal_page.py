"""The Python examples of docs/kaimal.md (user spectra, user coherence) run as written: their asserts are the page's
claims."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("keyword", ["spectrum=", "coherence="])
def test_the_user_examples_run_as_written(tmp_path, keyword):
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "kaimal.md").read_text(), re.S)
    code = next(b for b in blocks if keyword in b)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, env=env,
                         timeout=600)
    assert run.returncode == 0, run.stderr
