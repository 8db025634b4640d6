"""The core packages change no process-wide state and use no private zarr API (issue 28): the scan of
`grep -rn "gc\\.\\|signal\\.\\|atexit\\|sys.modules\\[\\|zarr.core" turbgen/{theory,spec,synthesis,store,validate,export,lidar}`,
done in Python over the packages' source files."""

from __future__ import annotations

import re
from pathlib import Path

import turbgen

CORE = ("theory", "spec", "synthesis", "store", "validate", "export", "lidar")
# the grep's basic regular expression: an unescaped "." matches any character, as in grep
FORBIDDEN = re.compile(r"gc\.|signal\.|atexit|sys.modules\[|zarr.core")


def _core_files():
    root = Path(turbgen.__file__).parent
    for package in CORE:
        for path in sorted((root / package).rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                yield path


def test_the_scan_finds_what_the_grep_would():
    hits = [s for s in ("gc.collect()", "signal.signal(", "atexit.register", 'sys.modules["x"]', "from zarr.core import sync",
                        "import ok") if FORBIDDEN.search(s)]
    assert len(hits) == 5 and "import ok" not in hits


def test_core_has_no_process_wide_side_effects_or_private_zarr_imports():
    files = list(_core_files())
    assert len(files) > 50  # the scan really covers the core packages
    hits = [f"{path}:{n}: {line.strip()}" for path in files
            for n, line in enumerate(path.read_text(errors="replace").splitlines(), 1) if FORBIDDEN.search(line)]
    assert hits == [], "\n".join(hits)
