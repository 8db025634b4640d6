"""Fixtures of the documentation tests."""

import pytest


@pytest.fixture()
def run_example(tmp_path, monkeypatch, capsys):
    """``run(code, name)``: a page's Python example run as a ``__main__`` module in tmp_path, in this process (as the
    pages' commands run: test_commands_as_written.py); returns what it printed, and an exception in it fails the test."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")

    def run(code: str, name: str) -> str:
        capsys.readouterr()
        exec(compile(code, name, "exec"), {"__name__": "__main__"})
        return capsys.readouterr().out

    return run
