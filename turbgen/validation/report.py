"""Rendering a ValidationReport: terminal table, JSON dictionary, PNG plots (matplotlib Agg).

JSON (``to_dict``; keys are stable, units in the names)::

    schema            "turbgen-validate/1"
    store, model      path of the store, "mann" | "kaimal"
    passed, failed    overall verdict (bool), names of the failed metrics
    alpha             per-metric false-failure probability of a correct field
    settings          nperseg, window, overlap, segments, effective_segments, rotor_radius_m,
                      rotor_points, separations_m [[dy, dz], ...], long_points_per_plane
    band              what the grid resolves and the band compared (f_min_hz, f_max_hz, k1_min_rad_m,
                      k1_max_rad_m, welch_df_hz, record_df_hz, k2/k3_nyquist_rad_m, Mann: box_y_m,
                      box_z_m, k2/k3_min_rad_m; note)
    components        u, v, w: mean_m_s, sigma_m_s, sigma_expected_m_s (the model on this grid; Mann: on
                      the box lattice), sigma_band_m_s (continuous model band-limited to the grid's
                      frequencies and y, z Nyquist wavenumbers, no box sampling), sigma_model_m_s
                      (full model spectrum), ti, ti_expected
    metrics           name -> title, quantity, passed, max_abs_z, z_crit, n_tests,
                      worst {label, band_hz, estimate, expected, sigma, z}, tests [same keys ...]
    seconds           estimate, theory (alongside the estimates when run in parallel), verdict, total [s]
    constraints_note  only for a store conditioned on measurements: what the verdict means then"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from turbgen.validation.estimators import COMPONENTS
from turbgen.store.temporaries import write_atomically
from turbgen.validation.checks import ALPHA, Check, Curve, MetricResult

SCHEMA = "turbgen-validate/1"


def _check_dict(t: Check) -> dict:
    return {"label": t.label, "band_hz": None if t.band_hz is None else [t.band_hz[0], t.band_hz[1]],
            "estimate": t.estimate, "expected": t.expected, "sigma": t.sigma, "z": t.z}


def _metric_dict(m: MetricResult) -> dict:
    w = m.worst
    return {"title": m.title, "quantity": m.quantity, "passed": m.passed, "max_abs_z": m.max_abs_z,
            "z_crit": m.z_crit, "n_tests": len(m.checks), "worst": None if w is None else _check_dict(w),
            "tests": [_check_dict(t) for t in m.checks]}


def components(report) -> dict:
    """Per component of ``report``: mean [m/s], sigma [m/s] (estimated, expected on this grid, band-limited, full
    model), TI [-]."""
    est, th, U = report.estimates, report.theory, report.store.U_m_s
    out = {}
    for c in COMPONENTS:
        s, s_exp = math.sqrt(est.variance[c]), math.sqrt(th.variance(c))
        out[c] = {"mean_m_s": est.mean[c], "sigma_m_s": s, "sigma_expected_m_s": s_exp,
                  "sigma_band_m_s": math.sqrt(th.band_variance(c)), "sigma_model_m_s": th.sigma_model[c],
                  "ti": s / U, "ti_expected": s_exp / U}
    return out


def to_dict(report) -> dict:
    """The JSON-serialisable result of ``report`` (a ValidationReport; keys and units in the module docstring)."""
    est = report.estimates
    g = est.grid
    note = constraints_note(report.store.attrs)
    return {
        "schema": SCHEMA, "store": report.store.label, "model": report.store.model, "passed": report.passed,
        "failed": report.failed, "alpha": ALPHA,
        "settings": {
            "nperseg": est.setup.nperseg, "window": "hann", "overlap": 0.5, "segments": est.n_segments,
            "effective_segments": est.effective_segments, "rotor_radius_m": est.rotor_radius_m,
            "rotor_points": int(est.rotor_mask.sum()),
            "separations_m": [[a * g.dy_m, b * g.dz_m] for a, b in est.separations],
            "long_points_per_plane": int(est.long_iy.size * est.long_iz.size),
        },
        "band": {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in report.theory.band.items()},
        "components": components(report),
        "metrics": {m.name: _metric_dict(m) for m in report.metrics},
        "seconds": report.seconds,
    } | ({} if note is None else {"constraints_note": note})


def constraints_note(attrs) -> str | None:
    """For a store conditioned on measurements, what the validation means (a conditional sample is marginally one
    of the prior only for data from the same model: Hoffman & Ribak 1991); else None."""
    c = attrs.get("constraints")
    if c is None:
        return None
    return (f"constrained on {len(c['streams'])} measured series: the check applies only when the data came from the "
            "same model (then the conditioned field is marginally a sample of it); measured data that differ from the "
            "model pull the field's statistics towards theirs")


def _fmt_band(t: Check) -> str:
    if t.band_hz is None:
        return ""
    lo, hi = t.band_hz
    return f"{lo:.3g} Hz" if lo == hi else f"{lo:.3g}-{hi:.3g} Hz"


def table(report) -> str:
    """Readable multi-line summary of ``report`` (a ValidationReport) for the terminal."""
    est, band = report.estimates, report.theory.band
    lines = [
        f"store   {report.store.label} ({report.store.model})",
        f"welch   {est.setup.nperseg} samples/segment (Hann, 50 %), {est.n_segments} segments "
        f"(~{est.effective_segments:.1f} independent); band {band['f_min_hz']:.3g}-{band['f_max_hz']:.3g} Hz",
        f"grid    {band['note']}",
        f"rotor   R = {est.rotor_radius_m:g} m, {int(est.rotor_mask.sum())} grid points",
        "",
        f"{'comp':4s} {'mean m/s':>9s} {'sigma m/s':>10s} {'expected':>9s} {'band':>7s} {'model':>7s} {'TI':>7s}",
    ]
    for c, d in components(report).items():
        lines.append(f"{c:4s} {d['mean_m_s']:9.3f} {d['sigma_m_s']:10.3f} {d['sigma_expected_m_s']:9.3f} "
                     f"{d['sigma_band_m_s']:7.3f} {d['sigma_model_m_s']:7.3f} {d['ti']:7.3f}")
    lines += ["", f"{'metric':26s} {'result':6s} {'max|z|':>7s} {'z_crit':>6s} {'tests':>5s}  worst comparison"]
    for m in report.metrics:
        w = m.worst
        worst = "" if w is None else (
            f"{w.label} {_fmt_band(w)}: {w.estimate:.4g} vs {w.expected:.4g} (sd {w.sigma:.2g})")
        lines.append(f"{m.name:26s} {'pass' if m.passed else 'FAIL':6s} {m.max_abs_z:7.2f} {m.z_crit:6.2f} "
                     f"{len(m.checks):5d}  {worst}")
    verdict = "all metrics pass" if report.passed else f"FAILED: {', '.join(report.failed)}"
    lines += ["", f"result  {verdict} (per-metric false-failure probability {ALPHA:g})"]
    note = constraints_note(report.store.attrs)
    if note is not None:
        lines.append(f"note    {note}")
    return "\n".join(lines)


def _draw(ax, c: Curve, logy: bool, reference=None):
    """The estimate ``c`` with its 95 % band, the expectation and the continuous model (``reference`` (f [Hz], values))
    on ``ax``; premultiplied by f on a linear axis unless ``logy``."""
    w = 1.0 if logy else c.f_hz
    ax.fill_between(c.f_hz, w * c.lower, w * c.upper, color="C0", alpha=0.25, lw=0)
    ax.plot(c.f_hz, w * c.estimate, color="C0", lw=1.0, label="sim.")
    ax.plot(c.f_hz, w * c.expected, color="k", lw=1.2, ls="-", label="theo. (grid)")
    if reference is not None:
        ax.plot(reference[0], reference[1] * (1.0 if logy else reference[0]), color="0.4", lw=1.0, ls="--",
                label="model (continuous)")
    ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")


def plots(report, directory) -> list[Path]:
    """One PNG per metric with curves into ``directory`` (created if missing): the estimate with its 95 % band, the
    expectation on the grid, the continuous model where there is one; the paths."""
    from matplotlib.figure import Figure  # not pyplot: the user's backend and figure list stay as they are

    out_dir = Path(directory)
    out_dir.mkdir(parents=True, exist_ok=True)
    references = report.theory.reference() if report.theory.reference is not None else {}
    files = []
    for m in report.metrics:
        if not m.curves:
            continue
        if m.name.startswith("yz_coherence") or m.name.startswith("longitudinal"):
            fig = _coherence_figure(m)
        else:
            fig = Figure(figsize=(6, 4))
            ax = fig.subplots()
            logy = m.name != "uw_cross_spectrum"  # uw premultiplied, linear axis: the sign and the peak show
            _draw(ax, m.curves[0], logy, references.get(m.curves[0].label))
            ax.set_ylabel(f"S(f) [{m.quantity}]" if logy else "f Co_uw(f) [m^2/s^2]")
            ax.set_xlabel("f [Hz]")
            ax.legend(fontsize=8)
        fig.suptitle(f"{m.title}: {'pass' if m.passed else 'FAIL'} (max|z| {m.max_abs_z:.1f}, z_crit {m.z_crit:.1f})",
                     fontsize=9)
        fig.tight_layout()
        path = out_dir / f"{m.name}.png"
        write_atomically(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110), "the plot")
        files.append(path)
    return files


def _coherence_figure(m: MetricResult):
    from matplotlib.figure import Figure

    kinds = sorted({c.label.split()[0] for c in m.curves})
    fig = Figure(figsize=(5 * len(kinds), 4))
    axes = fig.subplots(1, len(kinds), squeeze=False)
    for ax, kind in zip(axes[0], kinds):
        curves = [c for c in m.curves if c.label.split()[0] == kind]
        if m.name.startswith("longitudinal"):  # the first plane (rotor) against the others, as in the paper
            first = curves[0].label.split()[1].split("-")[0] + "-"
            curves = [c for c in curves if c.label.split()[1].startswith(first)]
        step = max(1, -(-len(curves) // 6))  # at most 6 curves per panel
        for i, c in enumerate(curves[::step]):
            color = f"C{i % 10}"
            ax.fill_between(c.f_hz, c.lower, c.upper, color=color, alpha=0.2, lw=0)
            ax.plot(c.f_hz, c.estimate, color=color, lw=1.0, label=" ".join(c.label.split()[1:]))
            ax.plot(c.f_hz, c.expected, color=color, lw=1.0, ls="--")
        ax.set_xscale("log")
        ax.set_xlabel("f [Hz]")
        ax.set_ylabel(kind + (" [rad]" if kind == "phase" else " [-]"))
        if kind == "phase":
            ax.set_ylim(-np.pi, np.pi)
        ax.legend(fontsize=7, title="solid sim., dashed theo.", title_fontsize=7)
    return fig
