"""Bad inputs to every command: exit code 2, one stderr line naming the value, no traceback, nothing written.

Every case runs the click app in-process (CliRunner) inside a directory holding a small complete
Mann store (``mann.zarr``), a plain file (``afile``) and a user-written PNG in ``plots/``; the
directory listing must be the same afterwards. Each case names the substring(s) the error line
must contain (the bad value, or the range it is refused against). The cases cover unbounded
lists and sizes, memory checks, physical ranges, misleading messages and output naming, and a broad
sample of inputs that were always refused.
A subprocess case checks the installed console script prints the same single line.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from turbgen.cli import cli
from turbgen.theory import ranges

SMALL = ["--nt", "16", "--ny", "4", "--nz", "4", "--planes", "0,50"]
SWEEP = ["sweep", "--model", "mann", "--preset", "neutral", "--speeds", "10", "--seeds", "1"]
LONG_NAME = "a" * 300 + ".zarr"
HUGE = ["--nt", "65536", "--ny", "1024", "--nz", "1024"]

# (id, args, substrings the single error line must contain)
CASES = [
    # --- mann: physical ranges ---
    ("mann-L-1e300", ["mann", "--L", "1e300"], ["1e+300", "[1, 1000]"]),
    ("mann-L-1e-9", ["mann", "--L", "1e-9"], ["1e-09", "[1, 1000]"]),
    ("mann-L-1e6", ["mann", "--L", "1e6"], ["1e+06", "[1, 1000]"]),
    ("mann-L-0", ["mann", "--L", "0"], ["L (length scale, m) = 0"]),
    ("mann-L-neg", ["mann", "--L", "-5"], ["-5"]),
    ("mann-L-nan", ["mann", "--L", "nan"], ["nan", "not a finite number"]),
    ("mann-L-inf", ["mann", "--L", "inf"], ["inf"]),
    ("mann-L-text", ["mann", "--L", "abc"], ["'abc'", "--L"]),
    ("mann-gamma-neg", ["mann", "--gamma", "-0.1"], ["-0.1", "[0, 20]"]),
    ("mann-gamma-big", ["mann", "--gamma", "25"], ["25", "[0, 20]"]),
    ("mann-evo-0", ["mann", "--evo", "0"], ["evo", "= 0", "[1, 100000]"]),
    ("mann-evo-neg", ["mann", "--evo", "-1"], ["-1"]),
    ("mann-evo-1e12", ["mann", "--evo", "1e12"], ["1e+12"]),
    ("mann-evo-text", ["mann", "--evo", "abc"], ["'abc'", "frozen"]),
    ("mann-U-0", ["mann", "--U", "0"], ["U (mean wind speed, m/s) = 0", "[0.5, 100]"]),
    ("mann-U-200", ["mann", "--U", "200"], ["200"]),
    ("mann-ae-0", ["mann", "--ae", "0"], ["ae", "= 0"]),
    ("mann-ae-1e9", ["mann", "--ae", "1e9"], ["1e+09"]),
    ("mann-sigma-u-0", ["mann", "--sigma-u", "0"], ["sigma-u", "= 0"]),
    ("mann-sigma-u-1e30", ["mann", "--sigma-u", "1e30"], ["1e+30"]),
    ("mann-ti-0", ["mann", "--ti", "0"], ["ti", "= 0", "(0, 1]"]),
    ("mann-ti-2", ["mann", "--ti", "2"], ["= 2"]),
    ("mann-two-energies", ["mann", "--ae", "1", "--ti", "0.1"], ["--ae", "--ti"]),
    ("mann-factor1-0", ["mann", "--factor1", "0"], ["factor1 = 0", "(0, 3]"]),
    ("mann-factor1-5", ["mann", "--factor1", "5"], ["factor1 = 5"]),
    ("mann-factor2-0", ["mann", "--factor2", "0"], ["factor2 = 0"]),
    ("mann-factor2-11", ["mann", "--factor2", "11"], ["factor2 = 11"]),
    ("mann-lifetime", ["mann", "--lifetime", "foo"], ["'foo'", "--lifetime"]),
    ("mann-hub-0", ["mann", "--hub-height", "0"], ["hub height (m) = 0"]),
    ("mann-hub-1e5", ["mann", "--hub-height", "1e5"], ["100000"]),
    ("mann-pad-0", ["mann", "--pad-yz", "0"], ["pad-yz = 0", "[1, 8]"]),
    ("mann-pad-9", ["mann", "--pad-yz", "9"], ["pad-yz = 9"]),
    # --- mann: grid (items 2, 7, 10) ---
    ("mann-dt-1e12", ["mann", "--dt", "1e12"], ["dt (s) = 1e+12", "[0.001, 60]"]),
    ("mann-dt-0", ["mann", "--dt", "0"], ["dt (s) = 0"]),
    ("mann-dt-neg", ["mann", "--dt", "-1"], ["-1"]),
    ("mann-nt-1", ["mann", "--nt", "1"], ["nt = 1", "[2, 16777216]"]),
    ("mann-nt-0", ["mann", "--nt", "0"], ["nt = 0"]),
    ("mann-nt-huge", ["mann", "--nt", "99999999999"], ["99999999999"]),
    ("mann-nt-text", ["mann", "--nt", "1.5"], ["'1.5'", "--nt"]),
    ("mann-ny-1", ["mann", "--ny", "1"], ["ny = 1", "[2, 4096]"]),
    ("mann-ny-0", ["mann", "--ny", "0"], ["ny = 0", "[2, 4096]"]),  # issue 37: said [1, 16384], the Grid's range
    ("mann-nz-99999", ["mann", "--nz", "99999"], ["nz = 99999"]),
    ("mann-dy-1e9", ["mann", "--dy", "1e9"], ["dy (m) = 1e+09", "[0.01, 1000]"]),
    ("mann-dy-0", ["mann", "--dy", "0"], ["dy (m) = 0"]),
    ("mann-dz-neg", ["mann", "--dz", "-1"], ["dz (m) = -1"]),
    ("mann-planes-neg", ["mann", "--planes", "-50,0"], ["-50", "[0, 10000]"]),
    ("mann-planes-unsorted", ["mann", "--planes", "50,0"], ["50, 0", "increasing"]),
    ("mann-planes-dup", ["mann", "--planes", "0,50,50"], ["duplicate"]),
    ("mann-planes-far", ["mann", "--planes", "0,1e9"], ["1e+09"]),
    ("mann-planes-text", ["mann", "--planes", "0,a"], ["'a'", "--planes"]),
    ("mann-planes-empty", ["mann", "--planes", ""], ["--planes", "no number"]),
    ("mann-planes-inf", ["mann", "--planes", "0,inf"], ["'inf'", "finite"]),
    ("mann-planes-300", ["mann", "--planes", ",".join(str(i) for i in range(300))], ["300 values", "256"]),
    ("mann-gates-huge", ["mann", "--gates", "50:10000000:1"], ["50:10000000:1", "9999951 values", "256"]),
    ("mann-gates-backwards", ["mann", "--gates", "5:1:1"], ["'5:1:1'", "stop >= start"]),
    ("mann-gates-two", ["mann", "--gates", "1:2"], ["'1:2'", "start:stop:step"]),
    ("mann-gates-step0", ["mann", "--gates", "50:170:0"], ["'50:170:0'", "step > 0"]),
    ("mann-planes-and-gates", ["mann", "--planes", "0", "--gates", "50:60:10"], ["--planes", "--gates"]),
    ("mann-seed-neg", ["mann", "--seed", "-1", *SMALL], ["seed = -1"]),
    ("mann-seed-huge", ["mann", "--seed", "99999999999999999999999", *SMALL],
     ["99999999999999999999999", "outside the allowed range"]),
    ("mann-seed-text", ["mann", "--seed", "x"], ["'x'", "--seed"]),
    # too big for memory goes out of core (turbgen mann --memory), and then does not fit on the disk
    ("mann-memory", ["mann", *HUGE, "--ae", "0.3"], ["disk space"]),
    # --scheduler: a malformed address always; nothing listening, when the run would use it (out of core)
    ("mann-scheduler-bad", ["mann", *SMALL, "--scheduler", "notanaddress"], ["'notanaddress'", "tcp://HOST:PORT"]),
    ("mann-scheduler-closed", ["mann", *HUGE, "--ae", "0.3", "--scheduler", "tcp://127.0.0.1:1"],
     ["'tcp://127.0.0.1:1'", "cannot connect"]),
    # --- mann: other options ---
    ("mann-threads-0", ["mann", "--threads", "0"], ["--threads", "0"]),
    ("mann-chunks-0", ["mann", *SMALL, "--chunks", "0", "--out", "c.zarr"], ["chunks", "= 0"]),
    ("mann-preset", ["mann", "--preset", "nosuch"], ["'nosuch'", "neutral"]),
    ("mann-presets-file-alone", ["mann", "--presets-file", "afile"], ["--presets-file needs --preset"]),
    ("mann-config-missing", ["mann", "--config", "missing.toml"], ["missing.toml"]),
    ("mann-config-bad", ["mann", "--config", "afile"], ["afile"]),
    ("mann-bogus", ["mann", "--bogus"], ["--bogus"]),
    ("mann-missing-value", ["mann", "--L"], ["--L", "requires an argument"]),
    ("mann-extra-arg", ["mann", "extra"], ["turbgen mann:", "extra"]),
    # --- mann: output paths (items 6, 9, 10) ---
    ("mann-out-empty", ["mann", *SMALL, "--out", ""], ["--out = ''", "empty"]),
    ("mann-out-blank", ["mann", *SMALL, "--out", "  "], ["--out = '  '", "empty"]),
    ("mann-out-long", ["mann", *SMALL, "--out", LONG_NAME], ["305 bytes", "the maximum is 200"]),
    ("mann-out-under-file", ["mann", *SMALL, "--out", "afile/x.zarr"], ["afile", "is a file, not a directory"]),
    ("mann-out-no-parent", ["mann", *SMALL, "--out", "nodir/x.zarr"], ["nodir", "does not exist"]),
    ("mann-out-exists", ["mann", *SMALL, "--out", "mann.zarr"], ["mann.zarr", "--overwrite"]),
    ("mann-out-not-store", ["mann", *SMALL, "--out", "afile", "--overwrite"], ["afile", "not a turbgen store"]),
    # --- kaimal (item 7 and broad sample) ---
    ("kaimal-sigma-0", ["kaimal", "--sigma", "0,0,0"], ["sigma_u (m/s) = 0", "[0.001, 30]"]),
    ("kaimal-sigma-w0", ["kaimal", "--sigma", "1,1,0"], ["sigma_w (m/s) = 0"]),
    ("kaimal-sigma-1e30", ["kaimal", "--sigma", "1e30,1,1"], ["1e+30", "[0.001, 30]"]),
    ("kaimal-sigma-two", ["kaimal", "--sigma", "1,2"], ["'1,2'", "three values"]),
    ("kaimal-sigma-text", ["kaimal", "--sigma", "a,b,c"], ["'a'", "--sigma"]),
    ("kaimal-lengths-1e300", ["kaimal", "--lengths", "1e300,1,1"], ["1e+300", "[0.1, 10000]"]),
    ("kaimal-lengths-0", ["kaimal", "--lengths", "340,113,0"], ["L3", "= 0"]),
    ("kaimal-ayz-neg", ["kaimal", "--ayz", "-1"], ["a_yz", "-1"]),
    ("kaimal-ayz-big", ["kaimal", "--ayz", "1e6"], ["1e+06"]),
    # a coherence high far beyond a large grid: neither a torus nor a dense factor is affordable (was a 7986^2 torus)
    ("kaimal-ayz-small-big-grid", ["kaimal", "--nt", "256", "--ny", "64", "--nz", "64", "--ayz", "0.5"],
     ["a_yz = 0.5", "--ayz", "--lc", "64 x 64"]),
    ("kaimal-lc-0", ["kaimal", "--lc", "0"], ["Lc", "= 0"]),
    ("kaimal-ax-0", ["kaimal", "--ax", "0"], ["a_x", "= 0", "(0, 100]"]),
    ("kaimal-ax-200", ["kaimal", "--ax", "200"], ["= 200"]),
    ("kaimal-bx-neg", ["kaimal", "--bx", "-1"], ["b_x", "-1"]),
    ("kaimal-bx-5", ["kaimal", "--bx", "5"], ["b_x", "= 5"]),
    ("kaimal-ax-not-exp", ["kaimal", "--long-model", "kristensen", "--ax", "1"], ["a_x", "'kristensen'"]),
    ("kaimal-long-model", ["kaimal", "--long-model", "foo"], ["'foo'", "--long-model"]),
    ("kaimal-long-components", ["kaimal", "--long-components", "x"], ["'x'"]),
    ("kaimal-vw", ["kaimal", "--vw-coherence", "x"], ["'x'", "--vw-coherence"]),
    ("kaimal-class", ["kaimal", "--class", "Z"], ["'Z'", "--class"]),
    ("kaimal-U-0", ["kaimal", "--U", "0"], ["U (mean wind speed, m/s) = 0"]),
    ("kaimal-U-101", ["kaimal", "--U", "101"], ["101"]),
    ("kaimal-hub-neg", ["kaimal", "--hub-height", "-1"], ["-1"]),
    ("kaimal-nt-1", ["kaimal", "--nt", "1"], ["nt = 1"]),
    ("kaimal-dt-1e12", ["kaimal", "--dt", "1e12"], ["dt (s) = 1e+12"]),
    ("kaimal-ny-1", ["kaimal", "--ny", "1"], ["ny = 1"]),
    ("kaimal-nz-0", ["kaimal", "--nz", "0"], ["nz = 0", "[2, 4096]"]),
    ("kaimal-dy-1e9", ["kaimal", "--dy", "1e9"], ["dy (m) = 1e+09"]),
    ("kaimal-dz-0", ["kaimal", "--dz", "0"], ["dz (m) = 0"]),
    ("kaimal-planes-neg", ["kaimal", "--planes", "-50,0"], ["-50"]),
    ("kaimal-planes-unsorted", ["kaimal", "--planes", "100,50,0"], ["100, 50, 0", "increasing"]),
    ("kaimal-gates-huge", ["kaimal", "--gates", "50:10000000:1"], ["256"]),
    ("kaimal-seed-neg", ["kaimal", "--seed", "-1"], ["seed = -1"]),
    ("kaimal-seed-huge", ["kaimal", "--seed", str(2**64)], [str(2**64), "outside the allowed range"]),
    ("kaimal-preset", ["kaimal", "--preset", "nosuch"], ["'nosuch'"]),
    ("kaimal-threads", ["kaimal", "--threads", "0"], ["--threads"]),
    ("kaimal-threads-huge", ["kaimal", "--threads", "100000"], ["--threads", "100000", "256"]),
    ("mann-threads-huge", ["mann", "--threads", "100000"], ["--threads", "100000", "256"]),
    ("sweep-workers-huge", [*SWEEP, "--out", "sw", "--workers", "5000"], ["workers = 5000", "256"]),
    # found by the sweep probe: every run failed in its worker (exit 1) after DIR and its manifest were written
    ("sweep-memory-tiny", [*SWEEP, "--out", "sw", "--memory", "1KiB"], ["1.0 KiB", "at least", "--memory"]),
    ("kaimal-memory", ["kaimal", *HUGE], ["memory"]),
    ("kaimal-out-empty", ["kaimal", *SMALL, "--out", ""], ["--out = ''"]),
    ("kaimal-out-long", ["kaimal", *SMALL, "--out", LONG_NAME], ["the maximum is 200"]),
    ("kaimal-out-under-file", ["kaimal", *SMALL, "--out", "afile/k.zarr"], ["is a file, not a directory"]),
    ("kaimal-out-exists", ["kaimal", *SMALL, "--out", "mann.zarr"], ["mann.zarr", "--overwrite"]),
    ("kaimal-config-missing", ["kaimal", "--config", "missing.json"], ["missing.json"]),
    ("kaimal-bogus", ["kaimal", "--sigmas", "1,1,1"], ["--sigmas"]),
    # --- sweep (items 2, 3, 6, 9) ---
    ("sweep-seeds-huge", [*SWEEP[:-1], "1-100000000", "--out", "sw"], ["'1-100000000'", "100000000 values", "10000"]),
    ("sweep-seeds-backwards", [*SWEEP[:-1], "5-1", "--out", "sw"], ["'5-1'", "backwards"]),
    ("sweep-seeds-empty", [*SWEEP[:-1], "", "--out", "sw"], ["--seeds", "no integer"]),
    ("sweep-seeds-text", [*SWEEP[:-1], "a", "--out", "sw"], ["'a'", "--seeds"]),
    ("sweep-seeds-neg", [*SWEEP[:-1], "-3", "--out", "sw"], ["'-3'"]),
    ("sweep-seeds-huge-int", [*SWEEP[:-1], str(2**64), "--out", "sw"], [str(2**64)]),
    ("sweep-no-out", SWEEP, ["missing: --out"]),
    ("sweep-nothing", ["sweep"], ["--config", "missing:"]),
    ("sweep-model", ["sweep", "--model", "foo", "--preset", "neutral", "--speeds", "10", "--seeds", "1", "--out", "sw"],
     ["'foo'", "mann, kaimal"]),
    ("sweep-preset", ["sweep", "--model", "mann", "--preset", "nosuch", "--speeds", "10", "--seeds", "1", "--out", "sw"],
     ["'nosuch'"]),
    ("sweep-speed-0", ["sweep", "--model", "mann", "--preset", "neutral", "--speeds", "0", "--seeds", "1", "--out", "sw"],
     ["U (mean wind speed, m/s) = 0"]),
    ("sweep-speeds-many", ["sweep", "--model", "mann", "--preset", "neutral", "--speeds", "1:100:0.1", "--seeds", "1",
                           "--out", "sw"], ["991 values", "200"]),
    ("sweep-speeds-dup", ["sweep", "--model", "mann", "--preset", "neutral", "--speeds", "10,10", "--seeds", "1",
                          "--out", "sw"], ["duplicate"]),
    ("sweep-runs-many", ["sweep", "--model", "mann,kaimal", "--preset", "neutral", "--speeds", "1:100:1",
                         "--seeds", "1-100", "--out", "sw"], ["20000 values", "10000"]),
    ("sweep-scheduler-closed", [*SWEEP, "--out", "sw", "--scheduler", "tcp://127.0.0.1:1"],
     ["'tcp://127.0.0.1:1'", "cannot connect"]),
    ("sweep-scheduler-bad", [*SWEEP, "--out", "sw", "--scheduler", "notanaddress"], ["'notanaddress'", "tcp://HOST:PORT"]),
    ("sweep-scheduler-scheme", [*SWEEP, "--out", "sw", "--scheduler", "http://x:80"], ["'http://x:80'"]),
    ("sweep-workers-0", [*SWEEP, "--out", "sw", "--workers", "0"], ["workers = 0"]),
    ("sweep-workers-and-scheduler", [*SWEEP, "--out", "sw", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"],
     ["workers and scheduler"]),
    ("sweep-memory-mann", [*SWEEP, "--out", "sw", *HUGE], ["mann_neutral_U10_seed1", "memory"]),
    ("sweep-memory-kaimal", ["sweep", "--model", "kaimal", "--preset", "neutral", "--speeds", "10", "--seeds", "1",
                             "--out", "sw", "--nt", "16777216", "--ny", "4096", "--nz", "4096"], ["memory"]),
    ("sweep-planes-neg", [*SWEEP, "--out", "sw", "--planes", "-50,0"], ["-50"]),
    ("sweep-planes-unsorted", [*SWEEP, "--out", "sw", "--planes", "50,0"], ["increasing"]),
    ("sweep-gates-huge", [*SWEEP, "--out", "sw", "--gates", "50:10000000:1"], ["256"]),
    ("sweep-ny-1", [*SWEEP, "--out", "sw", "--ny", "1"], ["ny = 1"]),
    ("sweep-dy-1e9", [*SWEEP, "--out", "sw", "--dy", "1e9"], ["1e+09"]),
    ("sweep-dt-1e12", [*SWEEP, "--out", "sw", "--dt", "1e12"], ["1e+12"]),
    ("sweep-chunks-0", [*SWEEP, "--out", "sw", "--chunks", "0"], ["chunks = 0"]),
    ("sweep-out-file", [*SWEEP, "--out", "afile"], ["afile"]),
    ("sweep-out-empty", [*SWEEP, "--out", ""], ["''", "empty"]),
    ("sweep-out-under-file", [*SWEEP, "--out", "afile/sw"], ["is a file, not a directory"]),
    ("sweep-out-long", [*SWEEP, "--out", "b" * 300], ["300 bytes"]),
    ("sweep-config-missing", ["sweep", "--config", "missing.toml"], ["missing.toml"]),
    ("sweep-config-and-model", ["sweep", "--config", "sweep.toml", "--model", "mann"], ["--model", "cannot be combined"]),
    ("sweep-config-seeds-empty", ["sweep", "--config", "seeds_empty.toml"], ["seeds", "''", "1-21"]),
    ("sweep-config-seeds-huge", ["sweep", "--config", "seeds_huge.toml"], ["'1-100000000'", "10000"]),
    ("sweep-config-seeds-backwards", ["sweep", "--config", "seeds_back.toml"], ["'9-2'", "backwards"]),
    ("sweep-config-no-out", ["sweep", "--config", "no_out.toml"], ["no output directory"]),
    ("sweep-workers-text", [*SWEEP, "--workers", "x"], ["'x'", "--workers"]),
    # --- theory / fit (items 6, 9, 10) ---
    ("theory-f-neg", ["theory", "spectra", "--f", "-0.1"], ["--f (Hz) = -0.1", "(0, 1000]"]),
    ("theory-f-0", ["theory", "spectra", "--f", "0"], ["--f (Hz) = 0"]),
    ("theory-f-huge", ["theory", "spectra", "--f", "1e9"], ["1e+09"]),
    ("theory-k1-neg", ["theory", "coherence", "--k1", "-1"], ["--k1 (rad/m) = -1"]),
    ("theory-f-and-k1", ["theory", "spectra", "--f", "0.1", "--k1", "0.1"], ["--k1", "--f"]),
    ("theory-f-text", ["theory", "spectra", "--f", "x"], ["'x'", "--f"]),
    ("theory-L-1e300", ["theory", "spectra", "--L", "1e300"], ["1e+300", "[1, 1000]"]),
    ("theory-L-0", ["theory", "longitudinal", "--L", "0"], ["L (length scale, m) = 0"]),
    ("theory-gamma", ["theory", "spectra", "--gamma", "-1"], ["gamma (Gamma, -) = -1"]),
    ("theory-U", ["theory", "rews", "--U", "0"], ["U (mean wind speed, m/s) = 0"]),
    ("theory-evo-0", ["theory", "spectra", "--evo", "0"], ["evo (gamma, s) = 0"]),
    ("theory-evo-text", ["theory", "spectra", "--evo", "x"], ["'x'", "frozen"]),
    ("theory-ti-0", ["theory", "spectra", "--ti", "0"], ["ti", "= 0"]),
    ("theory-two-energies", ["theory", "spectra", "--ae", "1", "--ti", "0.1"], ["--ae", "--ti"]),
    ("theory-sigma-u", ["theory", "spectra", "--sigma-u", "1e30"], ["1e+30"]),
    ("theory-factor1", ["theory", "spectra", "--factor1", "0"], ["factor1 = 0"]),
    ("theory-lifetime", ["theory", "spectra", "--lifetime", "x"], ["'x'", "--lifetime"]),
    ("theory-components", ["theory", "coherence", "--components", "xx"], ["'xx'"]),
    ("theory-plot-exists", ["theory", "spectra", "--plot", "plots/user.png"], ["plots/user.png", "--overwrite"]),
    ("theory-plot-under-file", ["theory", "spectra", "--plot", "afile/p.png"], ["is a file, not a directory"]),
    ("theory-plot-no-dir", ["theory", "spectra", "--plot", "nodir/p.png"], ["nodir", "does not exist"]),
    ("theory-plot-empty", ["theory", "spectra", "--plot", ""], ["--plot = ''"]),
    ("theory-nosuch", ["theory", "nosuch"], ["'nosuch'"]),
    ("theory-f-many", ["theory", "spectra", "--f", ",".join(["0.1"] * 100_001)], ["100001 values", "100000"]),
    ("theory-dx-neg", ["theory", "longitudinal", "--dx", "-5"], ["--dx (m) = -5", "[0, 10000]"]),
    ("theory-dy-huge", ["theory", "coherence", "--dy", "1e300"], ["--dy (m) = 1e+300"]),
    ("theory-dz-neg", ["theory", "coherence", "--dz", "-1"], ["--dz (m) = -1"]),
    ("theory-radius-neg", ["theory", "rews", "--radius", "-1"], ["--radius (m) = -1", "[0.5, 500]"]),
    ("theory-radius-huge", ["theory", "rews", "--radius", "1e300"], ["--radius (m) = 1e+300"]),
    ("fit-evolution-dx-huge", ["fit", "evolution", "--dx", "1e300"], ["--dx (m) = 1e+300"]),
    ("fit-kaimal-L", ["fit", "kaimal", "--L", "1e300"], ["1e+300"]),
    ("fit-kaimal-f", ["fit", "kaimal", "--f", "-1"], ["--f (Hz) = -1"]),
    ("fit-evolution-frozen", ["fit", "evolution", "--evo", "frozen"], ["evo", "frozen"]),
    ("fit-evolution-dx", ["fit", "evolution", "--dx", "0"], ["dx", "= 0"]),
    ("fit-plot-exists", ["fit", "kaimal", "--plot", "plots/user.png"], ["--overwrite"]),
    # --- validate ---
    ("validate-missing", ["validate", "nosuch.zarr"], ["nosuch.zarr"]),
    ("validate-file", ["validate", "afile"], ["afile"]),
    ("validate-no-arg", ["validate"], ["Missing argument 'STORE'"]),
    ("validate-radius-neg", ["validate", "mann.zarr", "--rotor-radius", "-1"], ["-1"]),
    ("validate-radius-text", ["validate", "mann.zarr", "--rotor-radius", "x"], ["'x'"]),
    ("validate-plots-file", ["validate", "mann.zarr", "--plots", "afile"], ["afile"]),
    ("validate-plots-exist", ["validate", "mann.zarr", "--plots", "plots"], ["'plots'", "--overwrite"]),
    ("validate-plots-under-file", ["validate", "mann.zarr", "--plots", "afile/p"], ["is a file, not a directory"]),
    ("validate-bogus", ["validate", "mann.zarr", "--bogus"], ["--bogus"]),
    # --- export ---
    ("export-plane-neg", ["export", "mann.zarr", "--format", "bts", "--out", "x.bts", "--plane", "-1"],
     ["plane = -1", "[0, 1]"]),
    ("export-plane-big", ["export", "mann.zarr", "--format", "bts", "--out", "x.bts", "--plane", "9"],
     ["plane = 9", "[0, 1]"]),
    ("export-plane-text", ["export", "mann.zarr", "--format", "bts", "--out", "x.bts", "--plane", "a"], ["'a'"]),
    ("export-format", ["export", "mann.zarr", "--format", "nope", "--out", "x"], ["'nope'", "--format"]),
    ("export-no-format", ["export", "mann.zarr", "--out", "x"], ["--format"]),
    ("export-no-out", ["export", "mann.zarr", "--format", "bts"], ["--out"]),
    ("export-no-store", ["export", "nosuch.zarr", "--format", "bts", "--out", "x.bts"], ["nosuch.zarr"]),
    ("export-store-file", ["export", "afile", "--format", "bts", "--out", "x.bts"], ["afile"]),
    ("export-out-under-file", ["export", "mann.zarr", "--format", "bts", "--out", "afile/x.bts"],
     ["is a file, not a directory"]),
    ("export-out-no-dir", ["export", "mann.zarr", "--format", "hdf5", "--out", "nodir/x.h5"], ["nodir", "does not exist"]),
    ("export-out-empty", ["export", "mann.zarr", "--format", "bts", "--out", ""], ["''"]),
    ("export-out-long", ["export", "mann.zarr", "--format", "hawc2", "--out", "c" * 300], ["the maximum is 200"]),
    ("export-out-exists", ["export", "mann.zarr", "--format", "bts", "--out", "afile"], ["afile", "--overwrite"]),
    ("export-hub-neg", ["export", "mann.zarr", "--format", "bts", "--out", "x.bts", "--hub-height", "-1"], ["-1"]),
    # --- info and the group ---
    ("info-missing", ["info", "nosuch.zarr"], ["nosuch.zarr"]),
    ("info-no-arg", ["info"], ["Missing argument"]),
    ("info-bogus", ["info", "mann.zarr", "--bogus"], ["--bogus"]),
    ("group-bogus", ["--bogus"], ["--bogus"]),
    ("group-nosuch", ["nosuch"], ["'nosuch'"]),
    # --- issue 27 sect. 3: tracebacks ---
    ("serve-memory-nan", ["serve", "--memory-budget", "nan"], ["--memory-budget", "nan", "not a finite number"]),
    # stores that decode but hold nonsense (workdir fixture): a finite garbage chunk, attributes out of range
    ("validate-garbage-chunk", ["validate", "garbage.zarr"],
     ["garbage.zarr", "3e+38", "u, plane index 0", "corrupted"]),
    ("info-garbage-chunk", ["info", "garbage.zarr"], ["garbage.zarr", "3e+38", "corrupted"]),
    ("export-garbage-chunk", ["export", "garbage.zarr", "--format", "bts", "--out", "g.bts"],
     ["garbage.zarr", "3e+38"]),
    ("lidar-garbage-chunk", ["lidar", "garbage.zarr", "--lidar", "axial_lidar.toml"], ["garbage.zarr", "3e+38"]),
    ("validate-garbage-no-rms", ["validate", "garbage_old.zarr"], ["garbage_old.zarr", "3e+38", "mean wind"]),
    ("validate-U-1e308", ["validate", "fast.zarr"], ["fast.zarr", "U_m_s", "1e+308", "[0.5, 100]"]),
    ("info-U-1e308", ["info", "fast.zarr"], ["fast.zarr", "1e+308", "[0.5, 100]"]),
    ("export-U-1e308", ["export", "fast.zarr", "--format", "bts", "--out", "f.bts"], ["fast.zarr", "1e+308"]),
    ("export-wnd-U-1e308", ["export", "fast.zarr", "--format", "wnd", "--out", "f.wnd"], ["1e+308"]),
    # --- accepted nonsense ---
    ("info-L-neg", ["info", "negative_L.zarr"], ["negative_L.zarr", "length_scale_m", "-5", "[1, 1000]"]),
    ("validate-L-neg", ["validate", "negative_L.zarr"], ["negative_L.zarr", "length_scale_m", "-5", "[1, 1000]"]),
    ("export-L-neg", ["export", "negative_L.zarr", "--format", "hdf5", "--out", "l.h5"], ["-5", "[1, 1000]"]),
    ("mann-config-dev-zero", ["mann", "--config", "/dev/zero"], ["/dev/zero", "not a regular file"]),
    ("mann-presets-file-dev-zero", ["mann", "--preset", "neutral", "--presets-file", "/dev/zero"],
     ["/dev/zero", "not a regular file (a character device)"]),
    ("kaimal-config-huge", ["kaimal", "--config", "huge.toml"],
     ["huge.toml", "at most 1048576 bytes", "2097150 bytes"]),
    ("sweep-config-huge", ["sweep", "--config", "huge.toml"], ["huge.toml", "1048576"]),
    ("mann-out-in-store", ["mann", *SMALL, "--out", "mann.zarr/inner.zarr"],
     ["mann.zarr/inner.zarr", "inside the store"]),
    ("kaimal-out-deep-in-store", ["kaimal", *SMALL, "--out", "mann.zarr/u/k.zarr"], ["inside the store"]),
    ("validate-plots-in-store", ["validate", "mann.zarr", "--plots", "mann.zarr/plots"], ["inside the store"]),
    ("sweep-out-store", [*SWEEP, *SMALL, "--out", "mann.zarr"],
     ["mann.zarr", "is a field store, not a sweep directory"]),
    ("sweep-out-in-store", [*SWEEP, *SMALL, "--out", "mann.zarr/sw"], ["inside the store"]),
    ("theory-lidar-beam-rate-tiny", ["theory", "lidar", "--lidar", "slow_lidar.toml"],
     ["beam_rate_hz", "1e-300", "[0.001, 1000]"]),
    ("lidar-run-beam-rate-tiny", ["lidar", "mann.zarr", "--lidar", "slow_lidar.toml"], ["beam_rate_hz", "1e-300"]),
    ("lidar-optimize-pitch-nan", ["lidar", "optimize", "--pitch-delay", "nan", "--ranges", "100", "--cones", "10"],
     ["pitch-delay", "nan", "not a finite number"]),
    ("lidar-optimize-pitch-nan-default-grid", ["lidar", "optimize", "--pitch-delay", "nan"], ["pitch-delay", "nan"]),
    ("lidar-optimize-pitch-neg", ["lidar", "optimize", "--pitch-delay", "-1e300", "--ranges", "100", "--cones", "10"],
     ["-1e+300", "[0, 10]"]),
    ("lidar-optimize-ranges-huge", ["lidar", "optimize", "--ranges", "100:1e300:1"],
     ["'100:1e300:1'", "1e+300", "500"]),
    # --- misleading ---
    ("mann-gates-1e300", ["mann", "--gates", "50:1e300:1"], ["'50:1e300:1'", "about 1e+300 values", "256"]),
    ("sweep-seeds-1e300", [*SWEEP[:-1], "1-" + "9" * 300, "--out", "sw"], ["about 1e+300 values", "10000"]),
    ("mann-out-is-a-file", ["mann", *SMALL, "--out", "afile"],
     ["afile", "not a turbgen store", "will not be replaced"]),
    ("kaimal-out-is-a-file", ["kaimal", *SMALL, "--out", "afile"],
     ["afile", "not a turbgen store", "will not be replaced"]),
    ("lidar-out-is-a-file", ["lidar", "mann.zarr", "--out", "afile"],
     ["afile", "not a zarr dataset", "will not be replaced"]),
    # --- issue 37 section 3: accepted nonsense (files written by _issue37_files) ---
    ("mann-ae-1e-300", ["mann", *SMALL, "--ae", "1e-300"], ["1e-300", "[1e-06, 100]"]),  # a field of float32 zeros
    ("mann-planes-empty-entry", ["mann", "--planes", "0,,50"], ["'0,,50'", "empty entry"]),
    ("mann-planes-trailing-comma", ["mann", "--planes", "0,50,"], ["'0,50,'", "empty entry"]),
    ("sweep-seeds-empty-entry", [*SWEEP[:-1], "1,,3", "--out", "sw"], ["'1,,3'", "empty entry"]),
    ("export-history-direction-1e308", ["export", "mann.zarr", "--format", "bts", "--out", "h.bts",
                                        "--mean-history", "history_dir_huge.csv"], ["1e+308", "[-360, 360]"]),
    ("export-history-speed-1e308", ["export", "mann.zarr", "--format", "bts", "--out", "h.bts",
                                    "--mean-history", "history_speed_huge.csv"], ["1e+308", "[0, 150]"]),
    ("mann-constrain-infinity", ["mann", *SMALL, "--ae", "0.3", "--constrain", "c_infinity.json", "--out", "c.zarr"],
     ["c_infinity.json", "Infinity", "null"]),
    ("mann-constrain-nan-literal", ["mann", *SMALL, "--ae", "0.3", "--constrain", "c_nan.json", "--out", "c.zarr"],
     ["c_nan.json", "NaN", "null"]),
    ("mann-constrain-1e30", ["mann", *SMALL, "--ae", "0.3", "--constrain", "c_1e30.json", "--out", "c.zarr"],
     ["c_1e30.json", "hub u_m_s", "1e+30", "[-150, 150]", "index 1"]),
    ("mann-constrain-los-inf", ["mann", *SMALL, "--ae", "0.3", "--constrain", "los_inf.csv", "--out", "c.zarr"],
     ["los_inf.csv", "v_los", "inf", "not a finite number"]),
    ("mann-constrain-los-1e30", ["mann", *SMALL, "--ae", "0.3", "--constrain", "los_1e30.csv", "--out", "c.zarr"],
     ["los_1e30.csv", "v_los", "1e+30", "[-150, 150]"]),
    ("mann-constrain-1001-sensors", ["mann", *SMALL, "--ae", "0.3", "--constrain", "c_1001.json", "--out", "c.zarr"],
     ["sensors: a list of 1001 items is too long (at most 1000)"]),
    ("info-garbage-sum", ["info", "garbage.sum"], ["garbage.sum", "not a .sum InflowWind can read"]),
    ("info-truncated-bts", ["info", "truncated.bts"], ["truncated.bts", "truncated or corrupted", "1000 bytes"]),
    ("info-array-meta-garbage", ["info", "badmeta.zarr"], ["badmeta.zarr", "u/zarr.json unreadable"]),
    ("validate-array-meta-garbage", ["validate", "badmeta.zarr"], ["badmeta.zarr", "u/zarr.json unreadable"]),
    ("export-array-meta-garbage", ["export", "badmeta.zarr", "--format", "bts", "--out", "b.bts"],
     ["badmeta.zarr", "u/zarr.json unreadable"]),
    ("info-array-meta-differs", ["info", "othermeta.zarr"], ["othermeta.zarr", "v/zarr.json differs"]),
]

SWEEP_FILE = 'models = ["mann"]\npresets = ["neutral"]\nspeeds = [10]\nseeds = {seeds}\n{out}'


def _listing(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A directory with a small complete store, a plain file, a PNG in plots/ and sweep files."""
    root = tmp_path_factory.mktemp("bad_input")
    cwd = os.getcwd()
    os.chdir(root)
    try:
        res = CliRunner().invoke(cli, ["mann", *SMALL[2:], "--nt", "128", "--ae", "0.3", "--out", "mann.zarr", "--threads", "1"])
        assert res.exit_code == 0, res.output
    finally:
        os.chdir(cwd)
    (root / "afile").write_text("not a store\n")
    (root / "plots").mkdir()
    (root / "plots" / "user.png").write_bytes(b"\x89PNG user figure")
    (root / "sweep.toml").write_text(SWEEP_FILE.format(seeds="[1]", out='out = "sw"'))
    (root / "seeds_empty.toml").write_text(SWEEP_FILE.format(seeds='""', out='out = "sw"'))
    (root / "seeds_huge.toml").write_text(SWEEP_FILE.format(seeds='"1-100000000"', out='out = "sw"'))
    (root / "seeds_back.toml").write_text(SWEEP_FILE.format(seeds='"9-2"', out='out = "sw"'))
    (root / "no_out.toml").write_text(SWEEP_FILE.format(seeds="[1]", out=""))
    (root / "huge.toml").write_text("# padding\n" * (2 * 2**20 // 10))  # 2.0 MiB of comments
    (root / "slow_lidar.toml").write_text(SLOW_LIDAR)
    # one beam along the shaft to the 50 m plane, 4 Hz: fits the small store (lidar run on it: exit 0)
    (root / "axial_lidar.toml").write_text(SLOW_LIDAR.replace("1e-300", "4.0").replace("100.0", "50.0")
                                           .replace("63.0", "5.0") + "fwhm_m = 1.0\n")
    _corrupt_copies(root)
    _issue37_files(root)
    return root


def _issue37_files(root: Path) -> None:
    """Inputs refused since issue 37: mean histories, constraint files and line-of-sight records holding
    non-numbers or implausible values, 1001 sensors, a garbage .sum, a truncated .bts and stores whose array
    metadata is garbage or differs from the consolidated copy."""
    import json
    import shutil

    (root / "history_dir_huge.csv").write_text("t,U,dir\n0,16,0\n100,16,1e308\n")
    (root / "history_speed_huge.csv").write_text("t,U\n0,16\n100,1e308\n")
    series = {"kind": "point-series", "time_s": [0.0, 0.5, 1.0],
              "sensors": [{"name": "hub", "x_m": 0.0, "y_m": 0.0, "z_m": 0.0, "u_m_s": [0.5, "X", -0.2]}]}
    for name, value in (("c_infinity.json", "Infinity"), ("c_nan.json", "NaN"), ("c_1e30.json", "1e30")):
        (root / name).write_text(json.dumps(series).replace('"X"', value))
    many = {**series, "sensors": [{**series["sensors"][0], "name": f"s{i}", "u_m_s": [0.1, 0.2, 0.3]}
                                  for i in range(1001)]}  # fmt: skip
    (root / "c_1001.json").write_text(json.dumps(many))
    rows = "".join(f"{0.25 * k},0,0,{{}}\n" for k in range(8))
    for name, value in (("los_inf.csv", "inf"), ("los_1e30.csv", "1e30")):
        values = ["0.1"] * 8
        values[3] = value
        (root / name).write_text("# lidar = axial_lidar.toml\n# U_m_s = 16\ntime_s,beam,gate,v_los_m_s\n"
                                 + rows.format(*values))
    (root / "garbage.sum").write_bytes(bytes(range(256)) * 2)
    res = CliRunner().invoke(cli, ["export", str(root / "mann.zarr"), "--format", "bts", "--out",
                                   str(root / "whole.bts")])
    assert res.exit_code == 0, res.output
    (root / "truncated.bts").write_bytes((root / "whole.bts").read_bytes()[:1000])
    for written in root.glob("whole*"):
        written.unlink()
    shutil.copytree(root / "mann.zarr", root / "badmeta.zarr")
    (root / "badmeta.zarr" / "u" / "zarr.json").write_text("garbage\n")
    shutil.copytree(root / "mann.zarr", root / "othermeta.zarr")
    meta_file = root / "othermeta.zarr" / "v" / "zarr.json"
    meta = json.loads(meta_file.read_text())
    meta["fill_value"] = 1.0  # consistent JSON, but not the array the consolidated metadata describes
    meta_file.write_text(json.dumps(meta))


SLOW_LIDAR = """kind = "pulsed"
mount = "nacelle"
ranges_m = [100.0]
beam_rate_hz = 1e-300
rotor_radius_m = 63.0
azimuth_deg = [0.0]
elevation_deg = [0.0]
"""


def _corrupt_copies(root: Path) -> None:
    """Copies of mann.zarr that still decode: a chunk of finite garbage (3e38 in every other value of the first
    chunk of u at plane 0, with and without the writer's rms attribute), U = 1e308, L = -5."""
    import json
    import shutil

    import numpy as np

    def copy(name, edit=None, garbage=False):
        dst = root / name
        shutil.copytree(root / "mann.zarr", dst)
        if garbage:
            chunk = dst / "u" / "c" / "0" / "0" / "0" / "0"
            values = np.fromfile(chunk, dtype="<f4")
            values[::2] = 3e38
            values.tofile(chunk)
        if edit is not None:
            meta = json.loads((dst / "zarr.json").read_text())
            edit(meta["attributes"])
            (dst / "zarr.json").write_text(json.dumps(meta))

    copy("garbage.zarr", garbage=True)
    copy("garbage_old.zarr", lambda a: a.pop("rms_m_s", None), garbage=True)  # a store written before rms_m_s
    copy("fast.zarr", lambda a: a.update(U_m_s=1e308))
    copy("negative_L.zarr", lambda a: a["parameters"].update(length_scale_m=-5))


@pytest.mark.parametrize("args, expected", [pytest.param(a, e, id=i) for i, a, e in CASES])
def test_bad_input_is_one_line_exit_2_nothing_written(workdir, monkeypatch, args, expected):
    monkeypatch.chdir(workdir)
    before = _listing(workdir)
    res = CliRunner().invoke(cli, args, prog_name="turbgen")
    err_lines = res.stderr.strip().splitlines()
    assert res.exit_code == 2, (res.exit_code, res.output, repr(res.exception))
    assert isinstance(res.exception, SystemExit), repr(res.exception)
    assert len(err_lines) == 1 and err_lines[0].startswith("Error: "), res.stderr
    assert res.stdout == "", res.stdout  # the refusal is the only output: nothing printed before it
    assert "Traceback" not in res.output
    for text in expected:
        assert text in err_lines[0], (text, err_lines[0])
    for digits in re.findall(r"\d{30,}", err_lines[0]):  # no unreadable number beyond those the user typed
        assert any(digits in str(a) for a in args), err_lines[0]
    assert _listing(workdir) == before


@pytest.mark.parametrize("command", ["mann", "kaimal"])
@pytest.mark.parametrize("out, overwrite", [("mann.zarr", []), ("afile", ["--overwrite"])])
def test_an_output_that_may_not_be_replaced_is_refused_before_the_banner(workdir, monkeypatch, command, out, overwrite):
    """Rerunning into an existing store without --overwrite (or over a non-store with it): the refusal is the only
    output, before the run's description is printed."""
    monkeypatch.chdir(workdir)
    res = CliRunner().invoke(cli, [command, *SMALL, "--out", out, *overwrite], prog_name="turbgen")
    assert res.exit_code == 2 and res.stdout == "", res.output
    assert len(res.stderr.strip().splitlines()) == 1 and out in res.stderr


def test_a_refusal_of_1001_sensors_is_a_short_line(workdir, monkeypatch):
    """The schema's message quoted every sensor: a 537 KB line for 1001 sensors (issue 37); now the count."""
    monkeypatch.chdir(workdir)
    res = CliRunner().invoke(cli, ["mann", *SMALL, "--ae", "0.3", "--constrain", "c_1001.json", "--out", "c.zarr"])
    assert res.exit_code == 2 and len(res.stderr) < 200, res.stderr[:300]


def test_serve_on_a_busy_port_is_refused_before_anything_is_made_or_printed(workdir, monkeypatch):
    """`serve --port <busy>` printed "listening on ..." and created --root before failing (issue 37): the port is
    bound first. Loopback only."""
    import socket

    pytest.importorskip("uvicorn")
    busy = socket.socket()
    busy.bind(("127.0.0.1", 0))
    busy.listen(1)
    port = busy.getsockname()[1]
    monkeypatch.chdir(workdir)
    before = _listing(workdir)
    try:
        res = CliRunner().invoke(cli, ["serve", "--port", str(port), "--root", "newroot"], prog_name="turbgen")
    finally:
        busy.close()
    assert res.exit_code == 2 and res.stdout == "", res.output
    assert res.stderr.strip().splitlines() == [res.stderr.strip()] and f"--port {port}" in res.stderr
    assert "cannot listen on 127.0.0.1" in res.stderr and "listening" not in res.output
    assert _listing(workdir) == before


@pytest.mark.parametrize("args", [[], ["theory"], ["fit"]])
def test_group_without_command_shows_its_help(args):
    res = CliRunner().invoke(cli, args, prog_name="turbgen")
    assert "Commands:" in res.output and "Error:" not in res.output


def test_case_ids_are_unique_and_many():
    ids = [c[0] for c in CASES]
    assert len(ids) == len(set(ids)) and len(ids) >= 150


def test_console_script_prints_one_line(workdir):
    """The installed entry point (not just the click app): one stderr line, exit 2, quickly."""
    for args, text in ((["mann", "--L", "1e300"], "1e+300"),):
        proc = subprocess.run([sys.executable, "-c", "from turbgen.cli import main; main()", *args], cwd=workdir,
                              capture_output=True, text=True, timeout=60)  # fmt: skip
        assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and text in proc.stderr, proc.stderr


def test_every_range_is_enforced_at_both_ends():
    """Each RANGES entry refuses just outside its bounds and accepts its bounds (closed ends)."""
    from turbgen.errors import ParameterError

    for key, r in ranges.RANGES.items():
        if r.integer:
            below, above = int(r.lo) - 1, int(r.hi) + 1
        else:
            below, above = (r.lo - abs(r.lo) * 1e-3 if r.lo else -1e-9), r.hi * (1 + 1e-3)
        for bad in (below, above):
            with pytest.raises(ParameterError, match="outside the allowed range"):
                ranges.check(key, bad)
        ranges.check(key, r.hi)
        if not r.lo_open:
            ranges.check(key, r.lo)
        else:
            with pytest.raises(ParameterError):
                ranges.check(key, r.lo)


def test_docs_show_the_ranges_table():
    # the reference of allowed ranges moved with the README's store section to docs/store.md
    page = (Path(__file__).resolve().parents[2] / "docs" / "store.md").read_text()
    assert ranges.markdown_table() in page


def test_default_store_names_differ_whenever_the_field_does():
    """Parameters the readable name does not show add a digest; defaults keep the short name."""
    from turbgen.spec.preset_runs import kaimal_run_keys
    from turbgen.spec.kaimal import KaimalRun
    from turbgen.spec.mann import MannRun

    mann = {name: MannRun.from_mapping(extra).default_store_name() for name, extra in {
        # explicit ae where the shape differs from the defaults: no energy-level quadrature for those
        "default": {}, "lifetime": {"lifetime": "mann", "ae": 0.3}, "factor2": {"factor2": 3.0, "ae": 0.3},
        "ae": {"ae": 0.3}, "pad": {"pad_yz": 1},
        "grid": {"grid": {"ny": 32}}, "sigma": {"sigma_u_m_s": 2.0}, "frozen": {"evo_time_s": None},
    }.items()}  # fmt: skip
    assert mann["default"] == "mann_U16_L49_G3.1_evo400_s1.zarr"
    assert mann["frozen"] == "mann_U16_L49_G3.1_evofrozen_s1.zarr"
    assert len(set(mann.values())) == len(mann)
    assert MannRun.from_mapping({"lifetime": "mann", "ae": 0.3}).default_store_name() == mann["lifetime"]

    kaimal = {name: KaimalRun.from_mapping(extra).default_store_name() for name, extra in {
        "default": {}, "kristensen": {"long_model": "kristensen"}, "class_b": {"turb_class": "B"},
        "uvw": {"long_components": "uvw"}, "sigma": {"sigma_m_s": [2.0, 1.6, 1.0]},
    }.items()}  # fmt: skip
    assert kaimal["default"] == "kaimal_U16_A_s1.zarr" and kaimal["class_b"] == "kaimal_U16_B_s1.zarr"
    assert kaimal["sigma"].startswith("kaimal_U16_sigma_s1_p")
    assert len(set(kaimal.values())) == len(kaimal)
    keys = kaimal_run_keys("stable", 16.0)
    stable = KaimalRun.from_mapping(keys)
    assert stable.default_store_name("stable", keys) == "kaimal_U16_stable_s1.zarr"
    assert KaimalRun.from_mapping({**keys, "a_yz": 5.0}).default_store_name("stable", keys).startswith(
        "kaimal_U16_stable_s1_p"
    )


@pytest.mark.parametrize("schema_name", ["mann-run", "kaimal-run"])
def test_run_schemas_accept_the_whole_ranges_table(schema_name):
    """The ranges table is the one place of allowed values: a run file's schema checks types and may hold
    looser bounds, but never refuses a value the table allows (so files and options obey the same ranges)."""
    import jsonschema

    from turbgen.spec.config import load_schema

    schema = load_schema(schema_name)
    props, grid = schema["properties"], schema["properties"]["grid"]["properties"]
    checked = 0
    for key, r in ranges.RANGES.items():
        sub = props.get(key) or grid.get(key)
        if sub is None:
            continue
        if sub.get("type") == "array":
            sub = sub["items"]
        lo = r.lo + (1e-9 if r.lo_open else 0)
        for value in (int(lo), int(r.hi)) if r.integer else (lo, r.hi):
            jsonschema.validate(value, sub)
        checked += 1
    assert checked >= 10


def test_scheduler_at_a_port_where_no_dask_scheduler_answers(workdir, monkeypatch):
    # an open port of some other server: dask's own connect would wait 30 s and raise a traceback;
    # refused in one line within the 3 s identity probe
    import socket
    import threading
    import time

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)
    accepted = []

    def accept_one():
        try:
            accepted.append(srv.accept())
        except OSError:  # the test closed the socket first
            pass

    threading.Thread(target=accept_one, daemon=True).start()
    address = f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    monkeypatch.chdir(workdir)
    before = _listing(workdir)
    t0 = time.monotonic()
    res = CliRunner().invoke(cli, [*SWEEP, "--out", "sw", "--scheduler", address])
    assert time.monotonic() - t0 < 15
    assert res.exit_code == 2 and res.stderr.strip().splitlines() == [res.stderr.strip()], res.output
    assert address in res.stderr and "no dask scheduler answered" in res.stderr
    assert _listing(workdir) == before
    srv.close()


def test_scheduler_at_a_port_where_a_server_answers_other_bytes(workdir, monkeypatch):
    # found with --scheduler tcp://10.255.255.1:8786 behind a proxy that answers every port: dask read the
    # reply's first 8 bytes as a frame length and raised MemoryError (a 3 EiB buffer) as a traceback
    import socket
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)

    def answer():  # every connection: the port probe's and dask's, until the test closes the socket
        while True:
            try:
                conn, _ = srv.accept()
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 4)
            except OSError:  # closed: an unhandled thread exception would surface as a warning in a later test
                return

    threading.Thread(target=answer, daemon=True).start()
    address = f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    monkeypatch.chdir(workdir)
    before = _listing(workdir)
    res = CliRunner().invoke(cli, [*SWEEP, "--out", "sw", "--scheduler", address])
    assert res.exit_code == 2 and res.stderr.strip().splitlines() == [res.stderr.strip()], res.output
    assert address in res.stderr and "no dask scheduler answered" in res.stderr
    assert _listing(workdir) == before
    srv.close()


@pytest.mark.parametrize("command", ["mann", "kaimal", "sweep"])
def test_grid_options_help_shows_the_ranges_that_are_enforced(command):
    """The help of --nt, --dt, --ny, --nz, --dy, --dz shows the interval of turbgen.theory.ranges, the one that
    refuses values (issue 27: the help said [1, 16384] where [2, 4096] was enforced)."""
    res = CliRunner().invoke(cli, [command, "--help"], prog_name="turbgen", terminal_width=200)
    assert res.exit_code == 0, res.output
    lines = {line.split()[0]: " ".join(line.split()) for line in res.output.splitlines()
             if line.strip().startswith("--")}
    for option, key in (("--nt", "nt"), ("--dt", "dt_s"), ("--ny", "ny"), ("--nz", "nz"), ("--dy", "dy_m"),
                        ("--dz", "dz_m")):
        assert ranges.RANGES[key].text() in lines[option], (option, lines[option])


def test_lidar_optimize_and_serve_help_show_their_ranges():
    res = CliRunner().invoke(cli, ["lidar", "optimize", "--help"], prog_name="turbgen", terminal_width=200)
    assert "[0, 10]" in " ".join(res.output.split()), res.output


@pytest.mark.parametrize("args", [["validate", "mann.zarr"], ["info", "mann.zarr"]], ids=["validate", "info"])
def test_ctrl_c_on_a_command_that_writes_nothing_says_only_interrupted(workdir, monkeypatch, args):
    """Ctrl-C (KeyboardInterrupt) in a command that writes no output: 'interrupted', exit 130, and no claim that
    unfinished output was removed (issue 27)."""
    def interrupt(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr("turbgen.validation.validate", interrupt)  # the command imports it when it runs
    monkeypatch.setattr("turbgen.api.products.info", interrupt)
    monkeypatch.chdir(workdir)
    res = CliRunner().invoke(cli, args, prog_name="turbgen")
    assert res.exit_code == 130, res.output
    assert res.stderr.strip().splitlines() == ["Error: interrupted"]
