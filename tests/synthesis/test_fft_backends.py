"""The FFT seam (turbgen.fft): every backend gives the same field to float32 round-off.

The bound of a difference between two backends: a float32 FFT of length n rounds each output to a few ulps of the
values' magnitude per butterfly stage, log2(n) stages, so a field made by transforms of lengths n_1, n_2, ... (the
Mann box's k3, k2 and k1 axes; the Kaimal torus's and time axis) differs by at most about
eps32 * max|u| * sum log2(n_i) between two correct FFT libraries. A wrong transform (a sign, a missing
normalisation, a conjugation) moves values by O(1) standard deviations, ~10^5 times that.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import turbgen
from turbgen import fft
from turbgen.cli import cli
from turbgen.errors import ParameterError
from turbgen.store import open_store

EPS32 = float(np.finfo(np.float32).eps)
MAST = Path(turbgen.__file__).parents[1] / "examples" / "mast.json"
SMALL = dict(nt=64, ny=6, nz=6, planes=[0, 50], seed=3)
OTHER = {"pyfftw": "scipy", "scipy": "pyfftw"}


def roundoff_bound(field: np.ndarray, lengths) -> float:
    """eps32 * max|u| * sum log2(n): the round-off two correct FFT libraries may differ by (module docstring)."""
    return EPS32 * float(np.max(np.abs(field))) * sum(math.log2(n) for n in lengths if n > 1)


def assert_same_to_roundoff(a, b, lengths) -> None:
    for c in "uvw":
        x, y = np.asarray(a[c]), np.asarray(b[c])
        diff, bound = float(np.max(np.abs(x - y))), roundoff_bound(y, lengths)
        assert diff <= bound, f"{c}: max |difference| {diff:.3g} > {bound:.3g} (std {np.std(y):.3g})"


@pytest.mark.parametrize("kind", fft.KINDS)
def test_the_built_in_plans_agree_on_strided_views(kind):
    rng = np.random.default_rng(7)
    real = kind in ("r2c", "dct1", "dst1")
    shape = (3, 10, 12)
    data = rng.standard_normal(shape) + (0 if real else 1j * rng.standard_normal(shape))
    results = {}
    for name in ("pyfftw", "scipy"):
        backend = fft.backend(name)
        buf = backend.empty(shape, np.float64 if real else np.complex128)
        view = buf[:, 1:9, :]  # strided along the transformed axis's neighbours, as the synthesis plans its views
        if kind == "r2c":
            out = backend.empty((3, 8, 7), np.complex128)
        elif kind == "c2r":
            out = backend.empty((3, 8, 2 * (12 - 1)), np.float64)
        else:
            out = view
        view[...] = data[:, 1:9, :]
        backend.plan(kind, view, out, -1).execute()
        results[name] = np.array(out)
    scale = float(np.max(np.abs(results["scipy"])))
    np.testing.assert_allclose(results["pyfftw"], results["scipy"], rtol=0, atol=8 * np.finfo(float).eps * scale)


def test_a_plan_runs_on_other_arrays_of_the_same_layout():
    backend = fft.backend()
    rng = np.random.default_rng(1)
    a, b = backend.empty((4, 9), np.complex64), backend.empty((4, 9), np.complex64)
    out = backend.empty((4, 16), np.float32)
    a[...] = rng.standard_normal((4, 9))
    b[...] = rng.standard_normal((4, 9))
    want = fft.oneshot().irfft(b.copy(), n=16, axis=1, norm="forward")
    plan = backend.plan("c2r", a, out, 1)
    plan.execute(b, out)
    np.testing.assert_allclose(out, want, rtol=0, atol=16 * EPS32 * float(np.abs(want).max()))


def test_mann_fields_of_both_backends_agree_to_roundoff():
    fields = {name: turbgen.mann(**SMALL, fft_backend=name) for name in ("pyfftw", "scipy")}
    assert [fields[n].attrs["fft_backend"] for n in fields] == ["pyfftw", "scipy"]
    nyp = fields["scipy"].attrs["parameters"]["pad_yz"] * SMALL["ny"]
    assert_same_to_roundoff(fields["pyfftw"], fields["scipy"], [SMALL["nt"], nyp, nyp])


def test_kaimal_fields_of_both_backends_agree_to_roundoff():
    fields = {name: turbgen.kaimal(**SMALL, fft_backend=name) for name in ("pyfftw", "scipy")}
    assert [fields[n].attrs["fft_backend"] for n in fields] == ["pyfftw", "scipy"]
    torus = 4 * 2 * (SMALL["ny"] - 1)  # at most 4 x the minimal torus 2 (n - 1) per axis (circulant.torus_cap)
    assert_same_to_roundoff(fields["pyfftw"], fields["scipy"], [SMALL["nt"], torus, torus])


def test_constrained_fields_of_both_backends_agree_to_roundoff():
    """The conditioning's own transforms (the system's lag DFTs, the correction's 2-D FFTs) change with the backend
    too; the correction is a bounded linear map of the sample, so the field's difference stays at round-off."""
    kw = dict(U=12, nt=64, ny=8, nz=8, dy=8, planes=[0, 40], pad_yz=1, constrain=[MAST])
    fields = {name: turbgen.mann(**kw, fft_backend=name) for name in ("pyfftw", "scipy")}
    assert fields["scipy"].attrs["constraints"]["n_samples"] == 128
    assert_same_to_roundoff(fields["pyfftw"], fields["scipy"], [64, 8, 8])


@pytest.mark.parametrize("name", ["pyfftw", "scipy"])
def test_each_backend_gives_the_same_bits_for_any_thread_count(name):
    one, two = (turbgen.mann(**SMALL, threads=t, fft_backend=name) for t in (1, 2))
    for c in "uvw":
        assert np.array_equal(one[c].values, two[c].values), c


def test_a_registered_backend_makes_every_transform_of_a_run(monkeypatch):
    """The seam is the only way to a transform: a backend that counts its plans and one-shot calls (delegating to
    scipy's) sees the whole Mann run and gives scipy's field to the bit."""
    calls = {"plan": 0, "oneshot": 0}

    class Counting(fft.ScipyBackend):
        name = "counting"

        def __init__(self):
            super().__init__()
            inner = self.oneshot

            class OneShot:
                def __getattr__(self, attr):
                    calls["oneshot"] += 1
                    return getattr(inner, attr)

            self.oneshot = OneShot()

        def plan(self, kind, inp, out, axis):
            calls["plan"] += 1
            return super().plan(kind, inp, out, axis)

    monkeypatch.setitem(fft._REGISTRY, "counting", Counting)
    monkeypatch.delitem(fft._MADE, "counting", raising=False)
    counted = turbgen.mann(**SMALL, fft_backend="counting")
    assert calls["plan"] > 0 and counted.attrs["fft_backend"] == "counting"
    scipy_field = turbgen.mann(**SMALL, fft_backend="scipy")
    for c in "uvw":
        assert np.array_equal(counted[c].values, scipy_field[c].values), c
    kaimal = turbgen.kaimal(**SMALL, fft_backend="counting")
    assert calls["oneshot"] > 0 and kaimal.attrs["fft_backend"] == "counting"


def test_the_command_records_its_backend_and_the_variable_selects_it(tmp_path, monkeypatch):
    other = OTHER[fft.current()]
    out = tmp_path / "a.zarr"
    args = ["mann", "--nt", "64", "--ny", "6", "--nz", "6", "--planes", "0,50", "--out", str(out)]
    res = CliRunner().invoke(cli, [*args, "--fft-backend", other])
    assert res.exit_code == 0, res.output
    assert open_store(out).attrs["fft_backend"] == other
    shown = CliRunner().invoke(cli, ["info", str(out)]).output  # which round-off a re-run reproduces
    assert f"by turbgen {turbgen.__version__}, FFT backend {other}\n" in shown, shown
    monkeypatch.setenv(fft.ENVIRONMENT_VARIABLE, other)
    assert turbgen.info(turbgen.kaimal(**SMALL))["fft_backend"] == other


def test_an_unknown_backend_is_one_line_and_writes_nothing(tmp_path, monkeypatch):
    out = tmp_path / "a.zarr"
    for command in ("mann", "kaimal"):
        res = CliRunner().invoke(cli, [command, "--nt", "64", "--ny", "6", "--nz", "6", "--planes", "0,50",
                                       "--fft-backend", "cupy", "--out", str(out)])  # fmt: skip
        assert res.exit_code == 2
        assert res.output.strip() == "Error: unknown FFT backend 'cupy' (allowed: pyfftw, scipy)"
        assert not out.exists()
    with pytest.raises(ParameterError, match=r"unknown FFT backend 'cupy' \(allowed: pyfftw, scipy\)"):
        turbgen.mann(**SMALL, fft_backend="cupy")
    monkeypatch.setenv(fft.ENVIRONMENT_VARIABLE, "cupy")
    with pytest.raises(ParameterError, match="TURBGEN_FFT_BACKEND"):
        turbgen.kaimal(**SMALL)


def test_one_backend_at_a_time_in_a_process():
    """The selection is process-wide while a call runs (its work hops between threads), so a concurrent call asking
    for another backend is refused, one asking for the same one shares it, and the selection ends with them."""
    before = fft.current()
    with fft.use("scipy"):
        with fft.use("scipy"):
            assert fft.current() == "scipy"
        assert fft.current() == "scipy"
        with pytest.raises(ParameterError, match="'pyfftw' asked for while another call .* runs with 'scipy'"):
            with fft.use("pyfftw"):
                pass
    assert fft.current() == before


def test_no_module_but_the_seam_calls_an_fft_library():
    """No module of turbgen but turbgen/fft.py imports or calls numpy.fft, scipy.fft or pyfftw; the one exception is
    the command's start-up (turbgen/cli/__init__.py imports pyfftw without its dask interface: no transform)."""
    root = Path(turbgen.__file__).parent
    use = re.compile(r"\b(np|numpy|scipy)\.fft\.\w|\bpyfftw\.\w|^\s*(import (pyfftw|scipy\.fft|numpy\.fft)|"
                     r"from (pyfftw|scipy\.fft|numpy\.fft)\b|from (scipy|numpy) import fft)", re.M)  # fmt: skip
    hits = {str(p.relative_to(root)): use.findall(p.read_text()) for p in root.rglob("*.py")}
    hits = {name: found for name, found in hits.items() if found}
    assert set(hits) == {"fft.py", "cli/__init__.py"}, hits
    assert len(hits["cli/__init__.py"]) == 1  # `import pyfftw`, nothing called
