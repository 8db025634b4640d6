"""Every command block of README.md and docs/*.md that claims to run, run as written (issue 27 §2).

What is collected: every fenced block marked ``bash``. Excluded, and so kept small and honest: blocks fenced as
``console`` (a synopsis with placeholders such as STORE or ``...``, a server that runs until stopped, or a command
whose full size needs a large disk; each has a runnable variant beside it) and a ``bash`` block directly preceded by
the line ``<!-- synopsis -->``.

How it runs: the blocks of one page run in order, in one fresh directory holding a copy of examples/, so a command
finds the stores and files that the commands before it wrote. A line ``A && B`` whose A is ``pip install ...``
runs B only (the set-up is what .ci/run does in a fresh virtualenv, and reinstalling here would repoint the test
venv); ``python -m pytest ...`` is not run (it is this test suite: .ci/run runs it). ``turbgen`` is this checkout's
command, run in this process by click's CliRunner in the page's directory (what the console script runs, less a
fresh interpreter's imports; tests/cli/test_entry_point.py is about the process), but in a subprocess when it gives
``--memory``: that budget bounds the whole process's resident memory. python and curl are not used by runnable
blocks.

Substitution rule (small sizes where a size option exists, the command otherwise as written):
- ``turbgen mann``, ``turbgen kaimal`` and ``turbgen sweep`` without ``--config`` get ``--nt 256`` (or their own
  smaller ``--nt``), ``--ny 16`` and ``--nz 16`` (or their own smaller values), and ``--dy`` / ``--dz`` scaled so
  the grid keeps the width the command asks for ((n - 1) d with the command's values, else the model's defaults:
  64 points 4.7 m apart for Mann, 31 points 5 m apart for Kaimal); runs from the example files keep their sizes
  (workstation-size already).
- a generator command without ``--out`` gets ``--out`` with the default store name of the command as written, so
  later commands that name that store (``mann_U16_L49_G3.1_evo400_s1.zarr``) find it;
- ``turbgen lidar optimize`` searches ``--ranges 200 --cones 16,18`` (two candidates: it still chooses) instead of
  its 11 x 11 default grid.
A command's exit code must be 0, or 1 for ``validate`` / ``lidar`` and 3 for ``sweep`` (a failed statistical
verdict on a short field is an outcome, not an error of the command). ``> FILE`` writes the command's stdout to FILE.

Repeated commands: several pages show the same command (the default ``turbgen mann --L 49 --gamma 3.1 --evo 400``
on five pages, ``turbgen kaimal`` on three). A command that reads nothing but its options and examples/ (``turbgen
mann`` / ``kaimal`` without ``--constrain``, ``turbgen theory`` / ``fit`` without ``--plot``) writes the same bytes
and prints the same text every time (same seed, same field): the first page to show it runs it, and a later page
showing it word for word (after the substitution rule) gets that run's exit code, stdout and a copy of its store.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import pytest
from click.testing import CliRunner

from turbgen.cli import cli

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.S | re.M)
SYNOPSIS = "<!-- synopsis -->"
SMALL_NT, SMALL_N = 256, 16
DEFAULT_YZ = {"mann": (64, 4.7), "kaimal": (31, 5.0), "sweep": (64, 4.7)}
VERDICT_COMMANDS = ("validate", "lidar")
KEEP_VALIDATOR_THEORY = True  # tests/conftest.py: a store validated on several pages reuses its predictions


def bash_blocks(page: Path) -> list[str]:
    """The runnable bash blocks of a page (see the module docstring)."""
    text = page.read_text()
    blocks = []
    for m in FENCE.finditer(text):
        before = text[: m.start()].rstrip().splitlines()
        if m.group(1) == "bash" and not (before and before[-1].strip() == SYNOPSIS):
            blocks.append(m.group(2))
    return blocks


def commands(block: str) -> list[list[str]]:
    """The commands of a block: continuation lines joined, comments dropped, ``&&`` chains split."""
    out = []
    for line in block.replace("\\\n", " ").splitlines():
        words = shlex.split(line, comments=True)
        while words:
            cut = words.index("&&") if "&&" in words else len(words)
            out.append(words[:cut])
            words = words[cut + 1:]
    return [c for c in out if c]


def _option(args: list[str], name: str):
    return args[args.index(name) + 1] if name in args else None


def _set(args: list[str], name: str, value) -> list[str]:
    if name in args:
        i = args.index(name)
        return [*args[: i + 1], str(value), *args[i + 2:]]
    return [*args, name, str(value)]


def _default_out(cmd: str, args: list[str]) -> str:
    """The store name ``turbgen cmd args`` writes when no --out is given (computed by the command's own code)."""
    from turbgen.spec.run_mapping import kaimal_run, mann_run_mapping
    from turbgen.cli import kaimal as kaimal_cli
    from turbgen.cli import mann as mann_cli
    from turbgen.spec.mann import MannRun

    opt = cli.get_command(None, cmd).make_context(cmd, list(args)).params
    files = (opt["config"], opt["preset"], opt["presets_file"])
    if cmd == "mann":
        mapping, _ = mann_run_mapping({name: opt[name] for name in mann_cli.RUN_OPTIONS}, *files)
        return MannRun.from_mapping(mapping).default_store_name()
    run, preset_keys = kaimal_run({name: opt[name] for name in kaimal_cli.RUN_OPTIONS}, *files)
    return run.default_store_name(opt["preset"], preset_keys or None)


def small(words: list[str]) -> list[str]:
    """The command with the substitution rule of the module docstring applied."""
    if words[:1] != ["turbgen"] or len(words) < 2:
        return words
    cmd, args = words[1], words[2:]
    if cmd == "lidar" and args[:1] == ["optimize"]:
        return ["turbgen", cmd, *_set(_set(args, "--ranges", "200"), "--cones", "16,18")]
    if cmd not in DEFAULT_YZ or "--config" in args:
        return words
    if cmd in ("mann", "kaimal") and "--out" not in args:
        args = [*args, "--out", _default_out(cmd, args)]
    n_default, d_default = DEFAULT_YZ["kaimal" if _option(args, "--model") == "kaimal" else cmd]
    given = list(args)
    args = _set(args, "--nt", min(int(_option(given, "--nt") or SMALL_NT), SMALL_NT))
    for n_opt, d_opt in (("--ny", "--dy"), ("--nz", "--dz")):
        n = int(_option(given, n_opt) or n_default)
        d = float(_option(given, d_opt) or _option(given, "--dy") or d_default)  # dz defaults to dy
        if n > SMALL_N:
            args = _set(_set(args, n_opt, SMALL_N), d_opt, f"{d * (n - 1) / (SMALL_N - 1):.6g}")
    return ["turbgen", cmd, *args]


def repeatable(run: list[str]) -> bool:
    """True for a command whose result depends only on its words and examples/ (see "Repeated commands")."""
    if run[1] in ("mann", "kaimal"):
        return "--constrain" not in run and all(not a.endswith((".json", ".toml")) or a.startswith("examples/")
                                                for a in run)
    return run[1] in ("theory", "fit") and "--plot" not in run


def runnable(words: list[str]) -> bool:
    """False for the set-up and test commands that .ci/run itself runs (see the module docstring)."""
    return words[:2] != ["pip", "install"] and words[:3] != ["python", "-m", "pytest"]


CASES = [(page, block) for page in PAGES for block in [bash_blocks(page)] if block]


def test_every_page_with_commands_is_collected():
    names = {page.name for page, _ in CASES}
    assert {"README.md", "mann.md", "kaimal.md", "theory.md", "validate.md"} <= names


class Ran(NamedTuple):
    """What a command gave: exit code, stdout and stderr."""

    exit_code: int
    stdout: str
    stderr: str


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    """The repeatable commands run so far in this session: words -> (result, kept copy of its --out or None)."""
    return {"dir": tmp_path_factory.mktemp("ran"), "runs": {}}


def _run(run: list[str], cwd: Path, ran: dict) -> Ran:
    """``turbgen`` + run[1:] in cwd, or the result of the same repeatable command run earlier (its --out copied)."""
    key = tuple(run)
    out = _option(run, "--out") if run[1] in ("mann", "kaimal") else None
    if key in ran["runs"]:
        r, kept = ran["runs"][key]
        if kept is not None:
            shutil.copytree(kept, cwd / out)
        return r
    if "--memory" in run:  # a budget of the process's memory: a fresh process (module docstring)
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
        done = subprocess.run([sys.executable, "-c", "from turbgen.cli import main; main()", *run[1:]], cwd=cwd,
                              env=env, capture_output=True, text=True, timeout=300)  # fmt: skip
        r = Ran(done.returncode, done.stdout, done.stderr)
    else:
        res = CliRunner().invoke(cli, run[1:], prog_name="turbgen")
        # an exception that is not the command's exit (SystemExit) is a crash, whatever exit code it left
        assert res.exception is None or isinstance(res.exception, SystemExit), f"{shlex.join(run)}: {res.exc_info}"
        r = Ran(res.exit_code, res.stdout, res.stderr)
    if r.exit_code == 0 and repeatable(run):
        kept = None
        if out is not None:
            kept = ran["dir"] / f"{len(ran['runs'])}" / out
            shutil.copytree(cwd / out, kept)
        ran["runs"][key] = (r, kept)
    return r


@pytest.mark.parametrize("page, blocks", CASES, ids=[p.name for p, _ in CASES])
def test_commands_run_as_written(page, blocks, tmp_path, ran, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    for block in blocks:
        for words in filter(runnable, commands(block)):
            assert words[0] == "turbgen", f"{page.name}: only turbgen commands run here, got {shlex.join(words)}"
            words, target = (words[: words.index(">")], words[words.index(">") + 1]) if ">" in words else (words, None)
            run = small(words)
            r = _run(run, tmp_path, ran)
            if target is not None:
                (tmp_path / target).write_text(r.stdout)
            allowed = (0, 1) if run[1] in VERDICT_COMMANDS else (0, 3) if run[1] == "sweep" else (0,)
            assert r.exit_code in allowed, f"{page.name}: {shlex.join(run)} -> {r.exit_code}\n{r.stderr[-2000:]}"
