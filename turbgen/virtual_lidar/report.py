"""`turbgen lidar STORE`: the virtual lidar's result against the preview theory of the store's own model.

The theory uses the sampling's discrete probe-volume weights, the box's (k2, k3) lattice for Mann stores and the
expected Welch estimate per bin (``welch_expectation``)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError
from turbgen.virtual_lidar import compare
from turbgen.virtual_lidar.run import LidarRun, lidar_attrs, run_lidar
from turbgen.spec.models import declaration, resolve
from turbgen.store.temporaries import write_atomically
from turbgen.validation.checks import MetricResult

DEFAULT_LIDAR = "nacelle-4beam"
# Theory is evaluated at the Welch bins up to this frequency only (its cost grows with the bins;
# gamma^2_RL of any preset is < 0.01 well below it, and the verdict skips bins with gamma^2 < MIN_COH2)
F_THEORY_MAX_HZ = 0.5


def mann_store_preview(fs, description, f_hz, radius_m: float):
    """PreviewSpectra of a Mann store at f_hz > 0 [Hz]: on its box's lattice, for rotor radius ``radius_m`` [m]."""
    from turbgen.virtual_lidar.preview import preview_spectra
    from turbgen.theory.lidar_lattice import BoxLattice
    from turbgen.validation.store_run import mann_box_from_attrs, mann_params_from_attrs

    g = fs.grid
    b = mann_box_from_attrs(fs.attrs, g)
    box = BoxLattice(b.nyp, b.nzp, g.dy_m, g.dz_m, g.nt * g.dt_s)
    return preview_spectra("mann", description, fs.U_m_s, f_hz=f_hz, radius_m=radius_m,
                           mann=mann_params_from_attrs(fs.attrs), box=box)


def kaimal_store_preview(fs, description, f_hz, radius_m: float):
    """PreviewSpectra of a Kaimal store at f_hz > 0 [Hz] as synthesised (its user spectrum and yz coherence tables,
    if any, as the validator reads them), for rotor radius ``radius_m`` [m]."""
    from turbgen.virtual_lidar.preview import preview_spectra
    from turbgen.validation.store_run import kaimal_model_from_attrs

    km = kaimal_model_from_attrs(fs.attrs)
    if km.long_model != "exp":
        raise ParameterError(f"lidar theory supports the exponential longitudinal coherence only "
                             f"(store has long_model = {km.long_model!r})")
    return preview_spectra("kaimal", description, fs.U_m_s, f_hz=f_hz, radius_m=radius_m, kaimal=km.kaimal,
                           a_x=km.a_x, b_x=km.b_x, long_components=km.long_components,
                           vw_coherence=km.vw_coherence == "exp", spectra=km.spectrum,
                           yz_coherence=km.coherence)  # the store's user tables, if any


def store_theory(fs, description, f_hz, radius_m: float, setup, n_samples: int | None = None):
    """The expected Welch S_RR, S_LL, S_RL [m^2 s^-2 Hz^-1] of ``description`` on store ``fs`` at ``f_hz`` > 0; with
    ``n_samples`` the result's ``n_eff`` holds the equivalent independent segments per bin. ParameterError if the
    store's model has no lidar theory, or a Kaimal store's options are outside it."""
    from turbgen.virtual_lidar.welch_expectation import expected_welch, theory_nodes

    record_s = fs.grid.nt * fs.grid.dt_s
    nodes, _ = theory_nodes(f_hz, setup, record_s)
    reference = declaration(fs.model, "store model").store_preview  # the model's, declared in turbgen.spec.models
    if reference is None:
        raise ParameterError(f"store model {fs.model!r} has no lidar theory")
    spectra = resolve(reference, "virtual_lidar")(fs, description, nodes, radius_m)
    return expected_welch(spectra, f_hz, setup, record_s, n_samples)


@dataclass
class LidarReport:
    """The virtual lidar's result on a store against the theory (:func:`lidar_report`): ``f_hz`` [Hz] the bins where the
    theory is evaluated, ``theory_numbers`` k05_rad_m, d_eddy_min_m, cutoff_hz."""
    store: str
    lidar: object
    run: LidarRun
    f_hz: np.ndarray
    coh2_theory: np.ndarray
    G_theory: np.ndarray
    theory_numbers: dict
    metric: MetricResult
    U_m_s: float

    @property
    def passed(self) -> bool:
        """Whether the coherence metric passed (every tested bin has |z| <= z_crit)."""
        return self.metric.passed

    def to_dict(self) -> dict:
        """The report, JSON-ready: store, lidar, rotor radius [m], mean wind, scans, Welch setup, TIs [-], simulated
        and theoretical numbers, the curves (simulated bins 1 .. Nyquist-1, ``f_theory`` [Hz]) and the verdict."""
        r, w = self.run, self.run.welch
        sl = slice(1, -1)
        worst = self.metric.worst
        return {
            "store": self.store,
            "lidar": lidar_attrs(self.lidar),
            "rotor_radius_m": r.rotor_radius_m,
            "mean_wind_added": r.samples.mean_wind_added,
            "shear_exponent": r.samples.shear_exponent if r.samples.mean_wind_added else None,
            "n_scans": int(r.samples.v_los.shape[0]),
            "welch": {"nperseg": int(w["f_hz"].size * 2 - 2), "n_segments": int(w["n_segments"]),
                      "n_eff": float(w["n_eff"])},
            "ti_lidar_uncorrected": r.ti_lidar,
            "ti_rotor": r.ti_rotor,
            "simulated": r.simulated,
            "theory": self.theory_numbers,
            "f_simulated": w["f_hz"][sl].tolist(),
            "coh2_RL_simulated": w["coh2_RL"][sl].tolist(),
            "G_RL_simulated": w["G_RL"][sl].tolist(),
            "f_theory": self.f_hz.tolist(),
            "coh2_RL_theory": self.coh2_theory.tolist(),
            "G_RL_theory": self.G_theory.tolist(),
            "verdict": {"passed": self.passed, "max_abs_z": self.metric.max_abs_z, "z_crit": self.metric.z_crit,
                        "n_tests": len(self.metric.checks),
                        "worst_f_hz": None if worst is None else worst.band_hz[0]},
        }

    def text(self) -> str:
        """A short summary: k_0.5 and cut-off simulated vs theory, the TIs and the verdict."""
        d = self.to_dict()

        def num(v, fmt):
            return "-" if v is None else format(v, fmt)

        s, t = d["simulated"], d["theory"]
        lines = [
            f"lidar {getattr(self.lidar, 'name', '')} on {self.store}",
            f"  scans {d['n_scans']}, Welch segments {d['welch']['n_segments']} (n_eff {d['welch']['n_eff']:.1f}), "
            f"rotor radius {d['rotor_radius_m']:g} m, mean wind {'added' if d['mean_wind_added'] else 'not added'}",
            f"  {'':22s}{'simulated':>12s}{'theory':>12s}",
            f"  {'k_0.5 [rad/m]':22s}{num(s['k05_rad_m'], '12.4f')}{num(t['k05_rad_m'], '12.4f')}",
            f"  {'cut-off [Hz]':22s}{num(s['cutoff_hz'], '12.4f')}{num(t['cutoff_hz'], '12.4f')}",
            f"  TI lidar (uncorrected) {d['ti_lidar_uncorrected']:.4f}, TI rotor {d['ti_rotor']:.4f}",
            f"  coherence gamma^2_RL: {'PASS' if self.passed else 'FAIL'} (max |z| {d['verdict']['max_abs_z']:.2f}, "
            f"z_crit {d['verdict']['z_crit']:.2f}, {d['verdict']['n_tests']} bins)",
        ]
        return "\n".join(lines)

    def __repr__(self) -> str:  # a notebook shows the summary, not the records behind it
        return self.text()

    def write(self, out, overwrite: bool = False) -> Path:
        """Write the lidar dataset ``out`` with the report's numbers as attributes (StoreError as check_output)."""
        from turbgen.virtual_lidar.dataset import write_dataset

        r = self.run
        d = self.to_dict()
        attrs = {"source_store": self.store, "lidar": d["lidar"], "rotor_radius_m": r.rotor_radius_m,
                 "mean_wind_added": bool(r.samples.mean_wind_added), "shear_exponent": float(r.samples.shear_exponent),
                 "mean_wind": r.samples.mean_wind_record, "U_m_s": self.U_m_s, "ti_lidar_uncorrected": r.ti_lidar,
                 "ti_rotor": r.ti_rotor, "simulated": d["simulated"], "theory": d["theory"], "verdict": d["verdict"]}
        return write_dataset(out, r.samples, r.t_arrival_s, r.u_LL, r.u_RR, attrs, overwrite=overwrite)

    def data(self):
        """The measurements as a constraint (``turbgen.mann(constrain=[report])``), exactly as written and read back."""
        import json

        from turbgen.virtual_lidar.dataset import LidarData
        from turbgen.store.attributes import jsonable

        r = self.run.samples
        stored = json.loads(json.dumps(jsonable({"lidar": self.to_dict()["lidar"], "mean_wind": r.mean_wind_record})))
        return LidarData(r.v_los.astype(np.float32).astype(float), np.asarray(r.time_s, float), stored["lidar"],
                         bool(r.mean_wind_added), float(r.shear_exponent), float(self.U_m_s), self.store,
                         stored["mean_wind"])  # fmt: skip

    def plots(self, directory) -> list[Path]:
        """Write ``lidar_coherence.png`` in ``directory``: gamma^2_RL and |G_RL| simulated (95 % band of the estimator)
        against theory, k_0.5 and cut-off marked (the style of Guo et al. 2023 Fig. 4 and Fu et al. 2023 Fig. 6)."""
        from matplotlib.figure import Figure  # not pyplot: the user's backend and figure list stay as they are

        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        c = self.metric.curves[0]
        w = self.run.welch
        fig = Figure(figsize=(6.4, 6.4))
        a1, a2 = fig.subplots(2, 1, sharex=True)
        a1.fill_between(c.f_hz, np.clip(c.lower, 0, 1), np.clip(c.upper, 0, 1), color="C0", alpha=0.25,
                        label="theory ± 1.96 sd of the estimator")
        a1.semilogx(c.f_hz, c.estimate, "k.-", lw=0.8, ms=3, label="simulated (Welch)")
        a1.semilogx(self.f_hz, self.coh2_theory, "C0", label="theory")
        a1.axhline(0.5, color="0.5", ls=":")
        sim, th = self.run.simulated, self.theory_numbers
        for v, ls in ((sim.get("k05_rad_m"), "--"), (th.get("k05_rad_m"), "-")):
            if v:
                a1.axvline(v * self.U_m_s / (2 * math.pi), color="C3", ls=ls, lw=0.8)
        a1.set_ylabel(r"$\gamma^2_{RL}$ [-]")
        a1.set_ylim(0, 1.05)
        a1.legend(fontsize=8)
        a1.set_title(f"{getattr(self.lidar, 'name', 'lidar')}: {'PASS' if self.passed else 'FAIL'}")
        a2.semilogx(w["f_hz"][1:-1], w["G_RL"][1:-1], "k.-", lw=0.8, ms=3, label="simulated")
        a2.semilogx(self.f_hz, self.G_theory, "C0", label="theory")
        a2.axhline(1 / math.sqrt(2), color="0.5", ls=":")
        for v, ls in ((sim.get("cutoff_hz"), "--"), (th.get("cutoff_hz"), "-")):
            if v:
                a2.axvline(v, color="C3", ls=ls, lw=0.8)
        a2.set_xlabel("f [Hz]")
        a2.set_ylabel(r"$|G_{RL}|$ [-]")
        a2.legend(fontsize=8)
        fig.tight_layout()
        path = directory / "lidar_coherence.png"
        write_atomically(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110), "the plot")
        return [path]


def lidar_report(fs, lidar=None, *, rotor_radius_m=None, add_mean_wind=False, shear_exponent=0.2,
                 nperseg=None, mean_wind=None) -> LidarReport:
    """Run the virtual lidar on the open store ``fs`` and compare with theory; ``lidar``: a description, preset or file
    (default DEFAULT_LIDAR); the rest as :func:`run_lidar`. ParameterError for an unknown lidar, one that does not fit
    the store, a signal too short, or a model without lidar theory."""
    from turbgen.virtual_lidar.description import LidarDescription, load_lidar

    desc = lidar if isinstance(lidar, LidarDescription) else load_lidar(lidar or DEFAULT_LIDAR)
    if rotor_radius_m is None:
        g = fs.grid
        half = min((g.ny - 1) * g.dy_m, (g.nz - 1) * g.dz_m) / 2.0
        rotor_radius_m = desc.rotor_radius_m if desc.rotor_radius_m <= half else None
    run = run_lidar(fs, desc, rotor_radius_m=rotor_radius_m, add_mean_wind=add_mean_wind,
                    shear_exponent=shear_exponent, nperseg=nperseg, mean_wind=mean_wind)
    fw = run.welch["f_hz"]
    f = fw[1:-1][fw[1:-1] <= F_THEORY_MAX_HZ]
    th = store_theory(fs, desc, f, run.rotor_radius_m, run.welch["setup"], run.u_LL.size)
    coh2_th = np.full(fw.size, np.nan)
    coh2_th[1 : 1 + f.size] = th.coh2_RL
    n_eff = np.full(fw.size, run.welch["n_eff"])  # (bins above F_THEORY_MAX_HZ are not tested)
    n_eff[1 : 1 + f.size] = th.n_eff
    metric = compare.coherence_metric(run.welch["f_hz"], run.welch["coh2_RL"], np.nan_to_num(coh2_th), n_eff)
    numbers = compare.preview_numbers(np.concatenate([[0.0], f]), np.concatenate([[1.0], th.coh2_RL]),
                                      np.concatenate([[th.G_RL[0]], th.G_RL]), fs.U_m_s)
    return LidarReport(fs.label, desc, run, f, th.coh2_RL, th.G_RL, numbers, metric, fs.U_m_s)
