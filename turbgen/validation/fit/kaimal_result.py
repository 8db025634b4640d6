"""The result of fitting the IEC Kaimal model to data (``turbgen.fit_kaimal``): values, intervals, a figure."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.validation.fit.kaimal_coherence import CoherenceFit
from turbgen.validation.fit.result import FitReport, misfit_notes

UNITS = {**{f"sigma_{c}_m_s": "m/s" for c in "uvw"}, **{f"length_{c}_m": "m" for c in "uvw"}, "a_yz": "-", "lc_m": "m"}
NAMES = tuple(UNITS)


@dataclass(frozen=True, eq=False, repr=False)
class KaimalFit(FitReport):
    """Kaimal sigma_k [m/s], L_k [m] and the u coherence a [-], Lc [m] fitted to data.

    Attributes
    ----------
    values : dict
        Name ("sigma_u_m_s" .. "length_w_m", "a_yz", "lc_m") -> FitValue (value, ci95); a name missing is not
        identified by the data (a component absent, one sensor: ``notes`` say why).
    chi2_dof : dict
        Spectrum ("uu", "vv", "ww") or "coherence" -> chi^2 / dof (about 1 +- sqrt(2 / dof) when the model holds).
    flags, notes : tuple of str
        Problems that make values unreliable (``ok`` False); what was assumed or not identified.
    U_m_s, source, nperseg, f_hz
        Mean wind [m/s], the data, Welch segment [samples], band centres [Hz].
    data, fitted, sd : dict
        Spectrum -> band estimates, the fitted expectation and their sd [m^2 s^-2 Hz^-1].
    coherence : CoherenceFit or None
        The u co-coherence per distance, fitted.
    """

    values: dict
    chi2_dof: dict
    flags: tuple
    notes: tuple
    U_m_s: float
    source: str
    nperseg: int
    f_hz: np.ndarray
    data: dict
    fitted: dict
    sd: dict
    coherence: CoherenceFit | None

    @classmethod
    def of(cls, data, bands, model, values, fits, cfit, flags, notes) -> KaimalFit:
        """The result of ``kaimal.fit_kaimal_data`` from its parts."""
        fitted, sd, chi2 = {}, {}, {}
        for c, (sol, cov, *_) in fits.items():
            s = c + c
            fitted[s] = model.expected(model.lines(*np.exp(sol.x)))
            sd[s] = fitted[s] * np.sqrt(bands.var_factor[s])  # one point's; the points' correlation aside
            chi2[s] = float(np.sum(sol.fun**2) / max(sol.fun.size - 2, 1))
            notes = [*notes, *misfit_notes(chi2[s], sol.fun.size - 2, f"the {c} spectrum")]
        if isinstance(cfit, str):
            notes, cfit = [*notes, cfit], None
        else:
            values = {**values, "a_yz": cfit.a, "lc_m": cfit.lc_m}
            chi2["coherence"], flags = cfit.chi2_dof, [*flags, *cfit.flags]
            notes = [*notes] + ([cfit.note] if cfit.note else [])
        return cls(values, chi2, tuple(flags), tuple(notes), data.U_m_s, data.source, bands.setup.nperseg,
                   bands.f_hz, {s: bands.values[s] for s in fitted}, fitted, sd, cfit)

    def to_dict(self) -> dict:
        """JSON-ready: {"sigma_u_m_s": {"value", "ci95", "identified"}, ..., "chi2_dof", "flags", "notes", ...}."""
        out = {n: {**self.values[n].to_dict(), "identified": True} if n in self.values else
               {"value": None, "ci95": None, "identified": False} for n in NAMES}
        for v in out.values():
            v.pop("held", None)
        return out | {"chi2_dof": self.chi2_dof, "flags": list(self.flags), "notes": list(self.notes),
                      "U_m_s": self.U_m_s, "source": self.source, "nperseg": self.nperseg}

    def table(self) -> str:
        """Terminal text: one line per parameter, the goodness of fit, flags and notes."""
        lines = [f"# Kaimal fit of {self.source} (U = {self.U_m_s:.4g} m/s)"]
        for n in NAMES:
            v, unit = self.values.get(n), UNITS[n]
            ci = None if v is None else ", ".join("not identified" if e is None else f"{e:.4g}" for e in v.ci95)
            lines.append(f"{n:>12s} = " + ("not identified" if v is None else
                                           f"{v.value:10.4g} {unit:4s} 95 % interval [{ci}]"))
        lines.append("chi2/dof: " + ", ".join(f"{k} {v:.3g}" for k, v in self.chi2_dof.items()) + " (about 1 when the "
                     "model holds)")
        return "\n".join(lines + [f"note: {n}" for n in self.notes] + [f"FLAG: {f}" for f in self.flags])

    def plot(self, path=None):
        """The band spectra f S(f) with 95 % bars and the fit; the u co-coherence per distance with 95 % bars and the
        fit (two or more sensors): a matplotlib Figure (a notebook cell shows it), also written to ``path`` as PNG."""
        from matplotlib.figure import Figure  # not pyplot: the user's backend and figure list stay as they are

        coh = self.coherence
        fig = Figure(figsize=(7 + 5 * bool(coh), 4.5))
        axes = fig.subplots(1, 1 + bool(coh), squeeze=False)
        f = self.f_hz
        for k, s in enumerate(self.data):
            axes[0, 0].errorbar(f, f * self.data[s], yerr=1.96 * f * self.sd[s], fmt="o", ms=3, color=f"C{k}",
                                label=f"{s[0]} data")
            axes[0, 0].plot(f, f * self.fitted[s], "-", color=f"C{k}", label=f"{s[0]} Kaimal fit")
        axes[0, 0].set_yscale("log")
        axes[0, 0].set_ylabel("f S(f) [m² s⁻²]")
        if coh:
            for k, r in enumerate(coh.r_m):
                axes[0, 1].errorbar(f, coh.data[k], yerr=1.96 * coh.sd[k], fmt="o", ms=3, color=f"C{k}",
                                    label=f"r = {r:g} m")
                axes[0, 1].plot(f, coh.fitted[k], "-", color=f"C{k}")
            axes[0, 1].set_ylabel(f"co-coherence of u (a = {coh.a.value:.3g}, Lc = {coh.lc_m.value:.3g} m)")
        for ax in axes[0]:
            ax.set_xscale("log")
            ax.set_xlabel("f [Hz]")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, format="png", dpi=120)
        return fig
