"""Files named by the user (issue 37 §2): every file option goes through turbgen.input_files, so a FIFO, a device, a
directory or a file over its kind's size cap is refused in one line (exit 2, nothing written) before anything is
read, and a deeply nested TOML/JSON file is refused instead of a RecursionError traceback.

A FIFO that the code under test opened for reading without refusing it would block forever: each FIFO here is fed
by a watchdog after WATCHDOG_S (a writer opens it, writes a byte and closes it), so such a regression fails the test
(with a message that is not the refusal) instead of hanging the suite.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner

import turbgen
from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.input_files import CONFIG, CONSTRAINTS, PROFILE_TABLE, check_input, read_input

WATCHDOG_S = 20.0
SMALL = ["--nt", "16", "--ny", "4", "--nz", "4", "--planes", "0,50"]
FIFO_RULE = "not a regular file (a FIFO or pipe)"
DEVICE_RULE = "not a regular file (a character device)"


class _Watchdog:
    """Opens each FIFO of a directory for writing after ``delay_s`` (unblocking a reader stuck in open), until
    stopped."""

    def __init__(self, fifos: list[Path], delay_s: float):
        self.fifos, self.stop = fifos, threading.Event()
        self.thread = threading.Thread(target=self._run, args=(delay_s,), daemon=True)
        self.thread.start()

    def _run(self, delay_s: float) -> None:
        if self.stop.wait(delay_s):
            return
        while not self.stop.wait(0.1):
            for f in self.fifos:
                try:
                    fd = os.open(f, os.O_WRONLY | os.O_NONBLOCK)
                except OSError:  # no reader: nobody is blocked on it
                    continue
                os.write(fd, b"x")
                os.close(fd)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """FIFOs with every suffix the file options dispatch on, oversized (sparse) files and deeply nested files."""
    root = tmp_path_factory.mktemp("bad_files")
    fifos = []
    for name in ("run.toml", "run.json", "points.json", "los.csv", "los.nc", "table.csv", "history.csv",
                 "lidar.toml", "presets.toml", "token", "sweep.toml", "spectrum.csv"):  # fmt: skip
        os.mkfifo(root / f"fifo_{name}")
        fifos.append(root / f"fifo_{name}")
    for name, size in (("big_points.json", CONSTRAINTS.max_bytes + 1), ("big_table.csv", PROFILE_TABLE.max_bytes + 1),
                       ("big_run.toml", CONFIG.max_bytes + 1)):  # fmt: skip
        with open(root / name, "wb") as f:
            f.truncate(size)  # sparse: no disk used
    with open(root / "big_points.csv", "wb") as f:  # a point-series CSV by its header, too large to read
        f.write(b"# sensor s = x_m=0, y_m=0, z_m=0\ntime_s,s:u_m_s\n")
        f.truncate(CONSTRAINTS.max_bytes + 1)
    (root / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    (root / "deep_points.json").write_text('{"sensors": ' + "[" * 100_000 + "]" * 100_000 + "}")
    (root / "deep.toml").write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    (root / "deep70.json").write_text("[" * 70 + "]" * 70)  # parses, but deeper than MAX_NESTING
    dog = _Watchdog(fifos, WATCHDOG_S)
    yield root
    dog.stop.set()
    dog.thread.join()


CASES = [  # (id, args with {d} for the directory, substrings of the single error line)
    ("config-fifo-toml", ["mann", "--config", "{d}/fifo_run.toml"], ["config", "fifo_run.toml", FIFO_RULE]),
    ("config-fifo-json", ["mann", "--config", "{d}/fifo_run.json"], ["fifo_run.json", FIFO_RULE]),
    ("kaimal-config-fifo", ["kaimal", "--config", "{d}/fifo_run.toml"], [FIFO_RULE]),
    ("sweep-config-fifo", ["sweep", "--config", "{d}/fifo_sweep.toml"], [FIFO_RULE]),
    ("presets-file-fifo", ["mann", "--presets-file", "{d}/fifo_presets.toml", "--preset", "x"], [FIFO_RULE]),
    ("constrain-fifo-json", ["mann", *SMALL, "--constrain", "{d}/fifo_points.json"], ["constraint file", FIFO_RULE]),
    ("constrain-fifo-csv", ["mann", *SMALL, "--constrain", "{d}/fifo_los.csv"], ["CSV file", FIFO_RULE]),
    ("fit-fifo-csv", ["fit", "mann", "{d}/fifo_los.csv"], ["CSV file", FIFO_RULE]),
    ("constrain-too-large-point-csv", ["mann", *SMALL, "--constrain", "{d}/big_points.csv"],
     ["constraint file", "may hold at most 67108864 bytes (64 MiB)"]),
    ("constrain-fifo-nc", ["mann", *SMALL, "--constrain", "{d}/fifo_los.nc"], ["line-of-sight", FIFO_RULE]),
    ("kaimal-constrain-fifo", ["kaimal", *SMALL, "--constrain", "{d}/fifo_points.json"], [FIFO_RULE]),
    ("export-mean-history-fifo", ["export", "{store}", "--format", "bts", "--out", "{d}/o.bts",
                                  "--mean-history", "{d}/fifo_history.csv"], ["mean history", FIFO_RULE]),
    ("export-profile-table-fifo", ["export", "{store}", "--format", "bts", "--out", "{d}/o.bts",
                                   "--profile", "table:{d}/fifo_table.csv"], ["profile table", FIFO_RULE]),
    ("lidar-mean-history-fifo", ["lidar", "{store}", "--lidar", "{d}/axial.toml", "--mean-wind",
                                 "--mean-history", "{d}/fifo_history.csv"], [FIFO_RULE]),
    ("lidar-file-fifo", ["lidar", "{store}", "--lidar", "{d}/fifo_lidar.toml"], [FIFO_RULE]),
    ("serve-token-file-fifo", ["serve", "--token-file", "{d}/fifo_token", "--port", "0", "--root", "{d}/srv"],
     ["token file", FIFO_RULE]),
    ("kaimal-spectrum-fifo", ["kaimal", *SMALL, "--spectrum", "{d}/fifo_spectrum.csv"], ["spectrum file", FIFO_RULE]),
    ("kaimal-spectrum-dev-zero", ["kaimal", *SMALL, "--spectrum", "/dev/zero"], ["spectrum file", DEVICE_RULE]),
    ("config-dev-zero", ["mann", "--config", "/dev/zero"], ["/dev/zero", DEVICE_RULE]),
    ("constrain-dev-zero", ["mann", *SMALL, "--constrain", "/dev/zero"], ["/dev/zero", DEVICE_RULE]),
    ("constrain-dev-urandom", ["mann", *SMALL, "--constrain", "/dev/urandom"], ["/dev/urandom", DEVICE_RULE]),
    ("profile-table-dev-zero", ["export", "{store}", "--format", "bts", "--out", "{d}/o.bts",
                                "--profile", "table:/dev/zero"], ["profile table", DEVICE_RULE]),
    ("mean-history-dev-urandom", ["export", "{store}", "--format", "bts", "--out", "{d}/o.bts",
                                  "--mean-history", "/dev/urandom"], ["mean history", DEVICE_RULE]),
    ("constrain-directory", ["mann", *SMALL, "--constrain", "{d}"], ["not a regular file (a directory)"]),
    ("constrain-too-large", ["mann", *SMALL, "--constrain", "{d}/big_points.json"], ["may hold at most 67108864 bytes (64 MiB)", "67108865 bytes"]),
    ("profile-table-too-large", ["export", "{store}", "--format", "bts", "--out", "{d}/o.bts",
                                 "--profile", "table:{d}/big_table.csv"], ["may hold at most 1048576 bytes (1 MiB)"]),
    ("config-too-large", ["mann", "--config", "{d}/big_run.toml"], ["(1 MiB)"]),
    ("config-deep-json", ["mann", "--config", "{d}/deep.json"], ["deep.json", "nested deeper than 64"]),
    ("config-deep-toml", ["mann", "--config", "{d}/deep.toml"], ["deep.toml", "nested deeper than 64"]),
    ("config-deep-70", ["mann", "--config", "{d}/deep70.json"], ["nested deeper than 64"]),
    ("constrain-deep-json", ["mann", *SMALL, "--constrain", "{d}/deep_points.json"], ["nested deeper than 64"]),
]


@pytest.fixture(scope="module")
def store(files):
    out = files / "m.zarr"
    res = CliRunner().invoke(cli, ["mann", *SMALL, "--ae", "0.3", "--out", str(out), "--threads", "1"])
    assert res.exit_code == 0, res.output
    (files / "axial.toml").write_text('kind = "pulsed"\nmount = "nacelle"\nranges_m = [50.0]\nbeam_rate_hz = 4.0\n'
                                      'rotor_radius_m = 5.0\nazimuth_deg = [0.0]\nelevation_deg = [0.0]\n'
                                      "fwhm_m = 1.0\n")  # fmt: skip
    return out


def _listing(d: Path) -> list[str]:
    return sorted(str(p.relative_to(d)) for p in d.rglob("*"))


@pytest.mark.parametrize("args, expected", [pytest.param(a, e, id=i) for i, a, e in CASES])
def test_a_file_that_is_not_a_small_regular_file_is_refused_in_one_line(files, store, monkeypatch, args, expected):
    monkeypatch.chdir(files)
    before = _listing(files)
    args = [a.format(d=files, store=store) for a in args]
    res = CliRunner().invoke(cli, args, prog_name="turbgen")
    err = res.stderr.strip().splitlines()
    assert res.exit_code == 2, (res.exit_code, res.output[-2000:], repr(res.exception))
    assert len(err) == 1 and err[0].startswith("Error: ") and "Traceback" not in res.output, res.output[-2000:]
    for text in expected:
        assert text in err[0], (text, err[0])
    assert _listing(files) == before


def test_the_api_refuses_the_same_files(files):
    with pytest.raises(ParameterError, match="a FIFO or pipe"):
        turbgen.mann(nt=16, ny=4, nz=4, planes=[0, 50], constrain=[files / "fifo_points.json"])
    with pytest.raises(ParameterError, match="a character device"):
        turbgen.mann(nt=16, ny=4, nz=4, planes=[0, 50], constrain=["/dev/zero"])
    with pytest.raises(ParameterError, match="nested deeper than 64"):
        turbgen.mann(nt=16, ny=4, nz=4, planes=[0, 50], constrain=[files / "deep_points.json"])


def test_read_input_reads_at_most_the_cap_and_names_the_rule(tmp_path):
    small = tmp_path / "a.toml"
    small.write_bytes(b"x = 1\n")
    assert read_input(small, CONFIG) == b"x = 1\n" and check_input(small, CONFIG) == small
    link = tmp_path / "link.toml"
    link.symlink_to(small)  # a link to a regular file is a regular file
    assert read_input(link, CONFIG) == b"x = 1\n"
    with pytest.raises(ParameterError, match=r"^config .*missing\.toml: does not exist$"):
        read_input(tmp_path / "missing.toml", CONFIG)
    with pytest.raises(ParameterError, match=r"config /dev/null: not a regular file \(a character device\)"):
        check_input("/dev/null", CONFIG)
