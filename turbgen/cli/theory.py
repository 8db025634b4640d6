"""`turbgen theory ...` and `turbgen fit ...`: model spectra, coherences and fits on the command line."""

from __future__ import annotations

import json
import math
import os

import click
import numpy as np

from turbgen.cli.options import evo_seconds, parse_floats, plot_figure, save_plot, stacked
from turbgen.errors import ParameterError
from turbgen.spec.defaults import MANN_DEFAULTS as D
from turbgen.theory import ranges
from turbgen.theory.params import LIFETIMES, MannParams, check_wind_speed


def _ranged(key: str, label: str):
    """Option callback checking the value against turbgen.theory.ranges.RANGES[key]."""
    return lambda ctx, param, value: ranges.check(key, value, label)


def _remember_overwrite(ctx, param, value):
    ctx.meta["theory_overwrite"] = value


def _plot_path(ctx, param, value):
    """--plot: refuse an existing file (without --overwrite) or an unusable directory before computing."""
    if value is None:
        return None
    from turbgen.store.paths import check_output_path

    p = check_output_path(value, "--plot")
    if p.exists() and not ctx.meta.get("theory_overwrite"):
        raise ParameterError(f"--plot = {value!r} exists; pass --overwrite to replace it")
    if not os.access(p.absolute().parent, os.W_OK):
        raise ParameterError(f"--plot = {value!r}: directory {str(p.absolute().parent)!r} is not writable")
    return value


def _model_options(f_default: str):
    """The decorator adding the model and evaluation-point options shared by every theory/fit command, with the
    command's own default frequency grid ``f_default`` in the help of --f (stated once, where it holds)."""
    return stacked([
        click.option("--L", "L", type=float, default=D["length_scale_m"], show_default=True, help="Mann length scale L [m]."),
        click.option("--gamma", type=float, default=D["gamma"], show_default=True, help="Shear anisotropy Γ [-]."),
        click.option("--ae", type=float, default=None,
                     help="αε^(2/3) [m^(4/3) s^-2]; default: σ_u of IEC class A at U (or --sigma-u / --ti)."),
        click.option("--sigma-u", "sigma_u", type=float, default=None, help="Target σ_u [m/s] (sets αε^(2/3))."),
        click.option("--ti", type=float, default=None, help="Target turbulence intensity σ_u/U [-] (sets αε^(2/3))."),
        click.option("--lifetime", type=click.Choice(LIFETIMES), default=D["lifetime"], show_default=True,
                     help="Eddy lifetime: guo (Guo et al. 2023, Eq. 6) or mann (Eq. 4)."),
        click.option("--factor1", type=float, default=D["factor1"], show_default=True, help="Small-k lifetime slope -factor1."),
        click.option("--factor2", type=float, default=D["factor2"], show_default=True,
                     help="Large-k slope -(2/3)factor2 of the evolution lifetime."),
        click.option("--evo", default=f"{D['evo_time_s']:g}", show_default=True, callback=evo_seconds,
                     help="Evolution time constant γ [s], or 'frozen' (no evolution)."),
        click.option("--U", "U", type=float, default=D["U_m_s"], show_default=True, help="Mean wind speed U [m/s]."),
        click.option("--k1", "k1_text", default=None, help="Wavenumbers a,b,c [rad/m] (instead of --f)."),
        click.option("--f", "f_text", default=None, help=f"Frequencies a,b,c [Hz]; default {f_default}."),
        click.option("--json", "as_json", is_flag=True, help="Print the result as JSON instead of a table."),
        click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default=None, callback=_plot_path,
                     help="Write a PNG plot (Guo et al. 2023, Fig. 2 style); an existing file needs --overwrite."),
        click.option("--overwrite", is_flag=True, is_eager=True, expose_value=False, callback=_remember_overwrite,
                     help="Replace an existing --plot file."),
    ])


_mann_options = _model_options("40 log-spaced, 1e-3..1 Hz")


def _params(L, gamma, ae, sigma_u, ti, lifetime, factor1, factor2, evo, U) -> MannParams:
    """MannParams from U and the model options (a command's ``**mann``); αε^(2/3) from --ae, --sigma-u, --ti or IEC
    class A at U (turbgen.spec.energy)."""
    from turbgen.spec.energy import resolve_ae

    U = check_wind_speed(U)
    if sum(v is not None for v in (ae, sigma_u, ti)) > 1:
        raise ParameterError("give at most one of --ae, --sigma-u, --ti")
    shape = MannParams(1.0, L, gamma, lifetime, factor1, factor2, evo)
    return shape.with_ae(resolve_ae(shape, U, ae=ae, sigma_u_m_s=sigma_u, ti=ti)[0])


def _points(k1_text, f_text, U):
    """(f [Hz], k1 [rad/m]) from --k1 or --f (k1 = 2 pi f / U)."""
    U = check_wind_speed(U)
    if k1_text is not None and f_text is not None:
        raise ParameterError("give either --k1 or --f, not both")
    if k1_text is not None:
        k1 = np.array([ranges.check("k1_rad_m", v, "--k1 (rad/m)") for v in parse_floats(k1_text, "--k1")])
        f = k1 * U / (2.0 * math.pi)
    else:
        values = parse_floats(f_text, "--f") if f_text is not None else np.logspace(-3, 0, 40)
        f = np.array([ranges.check("f_hz", v, "--f (Hz)") for v in values])
        k1 = 2.0 * math.pi * f / U
    return f, k1


def _emit(columns: dict, as_json: bool, extra: dict | None = None):
    """Print the columns as JSON (lists) or as an aligned table."""
    if as_json:
        out = {k: [float(x) for x in np.atleast_1d(v)] for k, v in columns.items()}
        out.update(extra or {})
        click.echo(json.dumps(out))
        return
    for k, v in (extra or {}).items():
        click.echo(f"# {k} = {v}")
    names = list(columns)
    click.echo("  ".join(f"{n:>12s}" for n in names))
    for row in zip(*(np.atleast_1d(columns[n]) for n in names)):
        click.echo("  ".join(f"{x:12.5g}" for x in row))


def _plot(path, x, curves: dict, xlabel: str, ylabel: str):
    """Curves over log x (Guo et al. 2023, Fig. 2 style), written as PNG."""
    fig, ax = plot_figure(figsize=(6, 4))
    for label, (y, style) in curves.items():
        ax.plot(x, y, style, label=label)
    ax.set(xscale="log", xlabel=xlabel, ylabel=ylabel)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    save_plot(fig, path, 120)


@click.group()
def theory():
    """Evaluate model spectra and coherences (Mann, space-time, Kaimal)."""


@theory.command(short_help="Mann one-point spectra F_ij(k1) (two-sided, m^3 s^-2).")
@_mann_options
def spectra(U, k1_text, f_text, as_json, plot_path, **mann):
    """Mann one-point spectra F_ij(k1) (two-sided, m^3 s^-2; Guo et al. 2023, Eq. 8)."""
    from turbgen.theory.mann_spectra import one_point_spectra

    p = _params(U=U, **mann)
    f, k1 = _points(k1_text, f_text, U)
    F = one_point_spectra(k1, p)
    cols = {"k1": k1, "f": f, **{n: F[n] for n in ("F11", "F22", "F33", "F13")}}
    _emit(cols, as_json, {"ae": p.ae})
    if plot_path:
        curves = {c: (2.0 * k1 * F[n], s) for c, n, s in (("u", "F11", "-"), ("v", "F22", "--"), ("w", "F33", ":"))}
        _plot(plot_path, f, curves, "f [Hz]", "f S(f) [m² s⁻²]")


@theory.command(short_help="yz-plane coherence of the Mann model: coh2 and co-coherence.")
@_mann_options
@click.option("--dy", type=float, callback=_ranged("separation_m", "--dy (m)"), default=20.0, show_default=True, help="Lateral separation [m].")
@click.option("--dz", type=float, callback=_ranged("separation_m", "--dz (m)"), default=20.0, show_default=True, help="Vertical separation [m].")
@click.option("--components", type=click.Choice(["uu", "vv", "ww", "uw"]), default="uu", show_default=True)
def coherence(U, k1_text, f_text, as_json, plot_path, dy, dz, components, **mann):
    """yz-plane coherence of the Mann model: coh2 (Eq. 9) and co-coherence (Eq. 10)."""
    from turbgen.theory.mann_spectra import yz_coherence

    p = _params(U=U, **mann)
    f, k1 = _points(k1_text, f_text, U)
    i, j = ("uvw".index(components[0]), "uvw".index(components[1]))
    coh2, cocoh = yz_coherence(k1, p, i, j, dy, dz)
    _emit({"k1": k1, "f": f, "coh2": coh2, "cocoh": cocoh}, as_json)
    if plot_path:
        _plot(plot_path, f, {"coh²": (coh2, "-"), "co-coherence": (cocoh, "--")}, "f [Hz]", "coherence [-]")


@theory.command(short_help="Longitudinal (magnitude-squared) coherence of u from the space-time tensor.")
@_mann_options
@click.option("--dx", type=float, callback=_ranged("separation_m", "--dx (m)"), default=100.0, show_default=True, help="Longitudinal separation [m].")
def longitudinal(U, k1_text, f_text, as_json, plot_path, dx, **mann):
    """Longitudinal (magnitude-squared) coherence of u from the space-time tensor (Guo et al. 2023, Eq. 16)."""
    from turbgen.theory.space_time import longitudinal_coherence

    p = _params(U=U, **mann)
    f, k1 = _points(k1_text, f_text, U)
    coh2 = longitudinal_coherence(f, dx, U, p)
    _emit({"f": f, "k1": k1, "coh2": coh2}, as_json)
    if plot_path:
        _plot(plot_path, f, {f"coh² (Δx = {dx:g} m)": (coh2, "-")}, "f [Hz]", "coherence [-]")


@theory.command(short_help="Rotor-effective wind speed spectrum of the Mann model (two-sided).")
@_mann_options
@click.option("--radius", type=float, callback=_ranged("rotor_radius_m", "--radius (m)"), default=63.0, show_default=True, help="Rotor radius R [m].")
def rews(U, k1_text, f_text, as_json, plot_path, radius, **mann):
    """Rotor-effective wind speed spectrum of the Mann model (Guo et al. 2023, Eq. 24; two-sided, m^3 s^-2)."""
    from turbgen.theory.mann_spectra import one_point_spectra
    from turbgen.theory.rotor_effective import rews_spectrum_mann

    p = _params(U=U, **mann)
    f, k1 = _points(k1_text, f_text, U)
    s_rr = rews_spectrum_mann(k1, p, radius)
    f11 = one_point_spectra(k1, p)["F11"]
    _emit({"k1": k1, "f": f, "S_RR": s_rr, "F11": f11}, as_json)
    if plot_path:
        _plot(plot_path, f, {"point u": (2 * k1 * f11, "--"), f"REWS (R = {radius:g} m)": (2 * k1 * s_rr, "-")},
              "f [Hz]", "f S(f) [m² s⁻²]")


@click.group()
def fit():
    """Fit the Mann model to measured data (``fit mann DATA``), or Kaimal / exponential-coherence models to the Mann
    (space-time) model."""


@fit.command(short_help="Kaimal sigma_i, L_i and IEC a_yz, Lc fitted to the Mann model.")
@_model_options("1000 linear steps, 1e-3..1 Hz (Eq. 20)")
def kaimal(U, k1_text, f_text, as_json, plot_path, **mann):
    """Kaimal σ_i, L_i (Guo et al. 2023, Eq. 20) and IEC a_yz, Lc (Eq. 21, dy = dz = 20 m) fitted to the Mann model.

    --f / --k1 set the Eq. 20 grid."""
    from turbgen.theory.fitting import fit_kaimal_spectra, fit_yz_coherence
    from turbgen.theory.kaimal import kaimal_spectrum
    from turbgen.theory.mann_spectra import one_point_spectra

    p = _params(U=U, **mann)
    grid = None if (k1_text is None and f_text is None) else _points(k1_text, f_text, U)[0]
    res = fit_kaimal_spectra(p, U, grid)
    a_yz, lc = fit_yz_coherence(p, U)
    out = {"sigma_m_s": list(res["sigma_m_s"]), "length_scales_m": list(res["length_scales_m"]),
           "a_yz": a_yz, "lc_m": lc, "ae": p.ae}
    if as_json:
        click.echo(json.dumps(out))
    else:
        click.echo(f"# Mann: ae = {p.ae:.4g}, L = {p.length_scale_m:g} m, Gamma = {p.gamma:g}, U = {U:g} m/s")
        click.echo(f"{'comp':>5s}  {'sigma [m/s]':>12s}  {'L [m]':>10s}")
        for c, s, l in zip("uvw", res["sigma_m_s"], res["length_scales_m"]):
            click.echo(f"{c:>5s}  {s:12.4g}  {l:10.4g}")
        click.echo(f"a_yz = {a_yz:.4g}, Lc = {lc:.4g} m")
    if plot_path:
        f = np.logspace(-3, 0, 60)
        k1 = 2.0 * math.pi * f / U
        F = one_point_spectra(k1, p)
        curves = {}
        for c, n, s, l in zip("uvw", ("F11", "F22", "F33"), res["sigma_m_s"], res["length_scales_m"]):
            curves[f"Mann {c}"] = (2.0 * k1 * F[n], "-")
            curves[f"Kaimal {c}"] = (f * kaimal_spectrum(f, s, l, U), "--")
        _plot(plot_path, f, curves, "f [Hz]", "f S(f) [m² s⁻²]")


@fit.command(short_help="a_x, b_x of the exponential longitudinal coherence (space-time fit).")
@_model_options("60 log-spaced, 3e-4..0.5 Hz")
@click.option("--dx", type=float, callback=_ranged("separation_m", "--dx (m)"), default=100.0, show_default=True, help="Longitudinal separation [m].")
def evolution(U, k1_text, f_text, as_json, plot_path, dx, **mann):
    """a_x, b_x of the exponential longitudinal coherence (Eq. 18) fitted to the space-time model (Eq. 22).

    --f / --k1 set the fitting grid."""
    from turbgen.theory.coherence_models import exponential_longitudinal
    from turbgen.theory.fitting import LONG_F_HZ, fit_longitudinal
    from turbgen.theory.space_time import longitudinal_coherence

    if mann["evo"] is None:  # before the (slow) energy-level quadrature
        raise ParameterError("--evo frozen: fit evolution needs an evolution time (frozen turbulence has coh = 1)")
    p = _params(U=U, **mann)
    grid = None if (k1_text is None and f_text is None) else _points(k1_text, f_text, U)[0]
    a_x, b_x = fit_longitudinal(p, U, dx, grid)
    click.echo(json.dumps({"a_x": a_x, "b_x": b_x}) if as_json else
               f"a_x = {a_x:.4g}, b_x = {b_x:.4g} 1/m  (dx = {dx:g} m, gamma = {p.evo_time_s:g} s, U = {U:g} m/s)")
    if plot_path:
        f = LONG_F_HZ if grid is None else grid
        coh2 = longitudinal_coherence(f, dx, U, p)
        model = exponential_longitudinal(dx, f, U, a_x, b_x) ** 2
        _plot(plot_path, f, {"space-time (Eq. 16)": (coh2, "-"), "exponential fit (Eq. 18)": (model, "--")},
              "f [Hz]", "coh² [-]")


def _attach_subcommands():
    from turbgen.cli.fit_data import fit_mann_command
    from turbgen.cli.fit_kaimal import with_data
    from turbgen.cli.theory_lidar import lidar_theory

    theory.add_command(lidar_theory)
    fit.add_command(fit_mann_command)
    with_data(kaimal)


_attach_subcommands()
