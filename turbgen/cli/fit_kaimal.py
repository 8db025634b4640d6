"""`turbgen fit kaimal DATA`: the IEC Kaimal model fitted to a point-series file or a store (without DATA: fitted to
the Mann model, ``turbgen.cli.theory.kaimal``, which this module gives the DATA argument and options)."""

from __future__ import annotations

import click
from click.core import ParameterSource

from turbgen.cli.fit_data import plots_dir, report, yz
from turbgen.errors import ParameterError

PLOT_NAME = "fit_kaimal.png"
MODEL_OPTIONS = ("L", "gamma", "ae", "sigma_u", "ti", "lifetime", "factor1", "factor2", "evo", "k1_text", "f_text",
                 "plot_path")
DATA_HELP = """

With DATA (a point-series JSON or CSV file of sensors with u, v, w, or a store): σ_i, L_i and the u coherence a_yz, Lc
fitted to the data's Welch spectra and u co-coherence, each band weighted by the estimator's variance, with 95 %
intervals (turbgen.fit_kaimal); --U is then the mean wind of fluctuation data, the model options are refused.
Exit 2 with one line when the fit is flagged."""


def with_data(cmd: click.Command) -> click.Command:
    """``cmd`` (the Kaimal fit to the Mann model) given the optional DATA argument and --nperseg, --point, --plots:
    with DATA the Kaimal model is fitted to the data."""
    theory = cmd.callback
    cmd.params = [click.Argument(["data"], required=False, type=click.Path()), *cmd.params,
                  click.Option(["--nperseg"], type=int, help="With DATA: Welch segment length [samples] (default "
                               "~nt/8, a power of 2)."),
                  click.Option(["--point", "points"], multiple=True, metavar="Y,Z",
                               help="With a store: fit the series at this grid point (y, z) [m] (repeat for a mast); "
                                    "default a sub-lattice of 8 x 8 points of the first plane."),
                  click.Option(["--plots"], type=click.Path(), callback=plots_dir(PLOT_NAME, "theory_overwrite"),
                               help=f"With DATA: directory for {PLOT_NAME} (spectra and u co-coherence, 95 % bars, "
                                    "the fit).")]
    flag = {p.name: p.opts[0] for p in cmd.params}

    def callback(data, nperseg, points, plots, **opts):
        ctx = click.get_current_context()
        given = [n for n in (*MODEL_OPTIONS, "U") if ctx.get_parameter_source(n) not in (ParameterSource.DEFAULT, None)]
        if data is None:
            if nperseg is not None or points or plots is not None:
                raise ParameterError("--nperseg, --point and --plots fit DATA: give DATA (a point-series file or a "
                                     "store)")
            return theory(**opts)
        bad = [flag[n] for n in given if n != "U"]
        if bad:
            raise ParameterError(f"{', '.join(bad)}: options of the Kaimal fit to the Mann model; with DATA the "
                                 "Kaimal model is fitted to the data")
        from turbgen.api.fit import fit_kaimal

        fit = fit_kaimal(data, U=opts["U"] if "U" in given else None, nperseg=nperseg,
                         points=[yz(p) for p in points] or None)
        report(ctx, fit, opts["as_json"], plots, PLOT_NAME)

    cmd.callback, cmd.help = callback, (cmd.help or "") + DATA_HELP
    cmd.short_help = "Kaimal sigma_i, L_i and IEC a_yz, Lc fitted to the Mann model or to DATA."
    return cmd
