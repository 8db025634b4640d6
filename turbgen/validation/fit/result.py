"""The result of fitting the Mann model to data: values with 95 % intervals, goodness of fit, flags, a figure."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from turbgen.theory.params import MannParams

if TYPE_CHECKING:
    from turbgen.validation.fit.evolution import EvoFit

SPECTRUM_LABELS = {"uu": "u", "vv": "v", "ww": "w", "uw": "-uw (co-spectrum)", "los": "line-of-sight"}
MISFIT_P = 1e-3  # chi^2 tail probability below which a fit notes that the model misfits the data


def misfit_notes(chi2_dof: float, dof: int, what: str = "these data") -> list[str]:
    """[a note] when chi2/dof over ``dof`` degrees of freedom is beyond the chi^2 tail probability MISFIT_P (the
    whitened residuals of a right model are chi^2_dof distributed), else []."""
    from scipy.stats import chi2

    p = float(chi2.sf(chi2_dof * dof, dof)) if dof > 0 else 1.0
    if p >= MISFIT_P:
        return []
    return [f"the model misfits {what}: chi2/dof = {chi2_dof:.3g} over {dof} dof (tail probability {p:.1e} were the "
            "model right): the 95 % intervals, which assume it, are too narrow"]


class FitReport:
    """What the fit results share: ``ok`` and their ``table()`` as repr."""

    flags: tuple
    table: Callable[[], str]

    @property
    def ok(self) -> bool:
        """True when nothing is flagged."""
        return not self.flags

    def __repr__(self) -> str:  # a notebook shows the table, not the band arrays behind it
        return self.table()


@dataclass(frozen=True)
class FitValue:
    """A fitted parameter: ``value``, its 95 % interval ``ci95`` (lo, hi) and ``sd_fit`` (the standard deviation of
    the fitted variable: of ln ae and ln L, of Gamma itself); ``ci95`` and ``sd_fit`` are None for a held value."""

    value: float
    ci95: tuple | None
    sd_fit: float | None

    @property
    def held(self) -> bool:
        return self.ci95 is None

    def to_dict(self) -> dict:
        return {"value": self.value, "ci95": None if self.ci95 is None else list(self.ci95), "held": self.held}


@dataclass(frozen=True, eq=False, repr=False)
class MannFit(FitReport):
    """Mann (1994) parameters fitted to measured or generated data (``turbgen.fit_mann``).

    Attributes
    ----------
    ae : FitValue
        alpha eps^(2/3) [m^(4/3) s^-2].
    length_scale_m : FitValue
        Length scale L [m].
    gamma : FitValue
        Shear anisotropy Gamma [-].
    chi2_dof : float
        Sum of squared whitened residuals / ``dof`` (about 1 +- sqrt(2 / dof) when the model holds).
    dof : int
        Bands fitted minus free parameters.
    flags : tuple of str
        Problems that make the values unreliable (no convergence, a range boundary); empty when none.
    notes : tuple of str
        What the fit held or assumed (e.g. Gamma held for one component).
    model : str
        "grid" (the lattice sum over a turbgen store's box) or "continuous" (sensor data).
    lifetime : str
        The model's eddy lifetime, ``MannParams.lifetime``: "guo" (Guo et al. 2023, Eq. 6-7) or "mann" (Mann 1994).
    U_m_s : float
        Mean wind speed [m/s] of k1 = 2 pi f / U.
    source : str
        The data fitted.
    nperseg : int
        Welch segment length [samples].
    f_hz : numpy.ndarray
        Band centres [Hz].
    data, fitted, sd : dict
        Spectrum ("uu", "vv", "ww", "uw"; "los" of a lidar dataset) -> band estimates, the fitted model's expectation
        of them and their standard deviations, one-sided [m^2 s^-2 Hz^-1].
    mean_wind : turbgen.validation.fit.mean_wind.MeanWindFit or None
        Shear exponent, roughness, veer and turbulence intensity of total-wind sensor data.
    bootstrap : dict or None
        The parametric bootstrap (``turbgen.api.fit.bootstrap_sd``): {"B", "sd", "sd_fit"}; None when not run.
    evolution : turbgen.validation.fit.evolution.EvoFit or None
        The eddy-evolution time fitted to the longitudinal coherence (None: no two points along x).
    cov_fit : numpy.ndarray or None
        (3, 3) covariance of the fitted (ln ae, ln L, Gamma), zero for a held one: what the gamma fit propagates.
    gain : numpy.ndarray or None
        (3, n) d (ln ae, ln L, Gamma) / d (band estimates, band-major ``data``): the fit's first-order response.
    """

    ae: FitValue
    length_scale_m: FitValue
    gamma: FitValue
    chi2_dof: float
    dof: int
    flags: tuple
    notes: tuple
    model: str
    U_m_s: float
    source: str
    nperseg: int
    f_hz: np.ndarray
    data: dict
    fitted: dict
    sd: dict
    mean_wind: object = None
    bootstrap: dict | None = None
    evolution: EvoFit | None = None
    cov_fit: np.ndarray | None = None
    gain: np.ndarray | None = None
    lifetime: str = "guo"

    @property
    def params(self) -> MannParams:
        """The fitted values as MannParams (frozen turbulence: the spectra do not fix an evolution time)."""
        return MannParams(self.ae.value, self.length_scale_m.value, self.gamma.value, self.lifetime)

    def to_dict(self) -> dict:
        """JSON-ready: {"ae": {"value", "ci95", "held"}, "length_scale_m": .., "gamma": .., "chi2_dof", ...}."""
        out = {n: getattr(self, n).to_dict() for n in ("ae", "length_scale_m", "gamma")}
        out.update(chi2_dof=self.chi2_dof, dof=self.dof, flags=list(self.flags), notes=list(self.notes),
                   model=self.model, lifetime=self.lifetime, U_m_s=self.U_m_s, source=self.source,
                   nperseg=self.nperseg, spectra=sorted(self.data),
                   **({"bootstrap": self.bootstrap} if self.bootstrap else {}))
        out["evo_time_s"] = self.evolution.to_dict() if self.evolution else {"value": None, "ci95": None, "held": True}
        return out | ({} if self.mean_wind is None else self.mean_wind.to_dict())

    def table(self) -> str:
        """Terminal text: one line per parameter, the goodness of fit, flags and notes."""
        lines = [f"# Mann fit of {self.source} ({self.model} model, {self.lifetime} lifetime, "
                 f"U = {self.U_m_s:.4g} m/s, spectra {', '.join(self.data)})"]
        for name, unit in (("ae", "m^(4/3) s^-2"), ("length_scale_m", "m"), ("gamma", "-")):
            v = getattr(self, name)
            ci = "held (not identified)" if v.held else f"95 % interval [{v.ci95[0]:.4g}, {v.ci95[1]:.4g}]"
            lines.append(f"{name:>15s} = {v.value:10.4g} {unit:13s} {ci}")
        if self.evolution:
            lo, hi = self.evolution.ci95
            lines.append(f"{'evo_time_s':>15s} = {self.evolution.value_s:10.4g} {'s':13s} 95 % interval [{lo:.4g}, "
                         f"{'inf (frozen)' if hi is None else f'{hi:.4g}'}]")
        lines.append(f"chi2/dof = {self.chi2_dof:.3g} (dof {self.dof}; 1 +- {math.sqrt(2 / max(self.dof, 1)):.2g} "
                     "expected when the model holds)")
        lines += [] if self.mean_wind is None else ["mean wind:", *self.mean_wind.lines()]
        if self.bootstrap:
            b = self.bootstrap
            lines.append(f"bootstrap sd (B = {b['B']}) / analytic sd: " + ", ".join(
                f"{n} {b['sd'][n]:.3g} / {b['sd_fit'][n]:.3g}" for n in b["sd"]) + " (of ln ae, ln L, Gamma)")
        lines += [f"note: {n}" for n in self.notes] + [f"FLAG: {f}" for f in self.flags]
        return "\n".join(lines)

    def plot(self, path=None):
        """The band spectra (f S(f), error bars +- 1.96 sd) and the fitted model, and the coherence with an evolution
        time: a matplotlib Figure (a notebook cell shows it), also written to ``path`` as PNG if given."""
        from matplotlib.figure import Figure  # not pyplot: the user's backend and figure list stay as they are

        panels = 1 + bool(self.evolution)
        fig = Figure(figsize=(7 + 5 * (panels - 1), 4.5))
        axes = fig.subplots(1, panels, squeeze=False)
        ax = axes[0, 0]
        if self.evolution:
            self.evolution.plot(axes[0, 1])
        f = self.f_hz
        for k, (s, label) in enumerate((s, SPECTRUM_LABELS[s]) for s in SPECTRUM_LABELS if s in self.data):
            sign = -1.0 if s == "uw" else 1.0
            color = f"C{k}"
            ax.errorbar(f, sign * f * self.data[s], yerr=1.96 * f * self.sd[s], fmt="o", ms=3, color=color,
                        label=f"{label} data")
            ax.plot(f, sign * f * self.fitted[s], "-", color=color, label=f"{label} fitted ({self.model})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("f [Hz]")
        ax.set_ylabel("f S(f) [m² s⁻²]")
        ax.set_title(f"L = {self.length_scale_m.value:.3g} m, Γ = {self.gamma.value:.3g}, "
                     f"αε^(2/3) = {self.ae.value:.3g}, χ²/dof = {self.chi2_dof:.2f}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, format="png", dpi=120)
        return fig
