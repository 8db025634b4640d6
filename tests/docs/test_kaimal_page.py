"""The Python examples of docs/kaimal.md (user spectra, user coherence) run as written: their asserts are the page's
claims."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("keyword", ["spectrum=", "coherence="])
def test_the_user_examples_run_as_written(run_example, keyword):
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "kaimal.md").read_text(), re.S)
    code = next(b for b in blocks if keyword in b)
    run_example(code, "docs/kaimal.md")
