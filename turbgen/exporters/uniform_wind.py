"""InflowWind uniform wind files (WindType 2, the text files IECWind writes) for IEC 61400-1 transients.

Layout: comment lines starting with ``!``, then one row per time with the 8 columns Time, WindSpeed,
WindDir, VertSpeed, HorizShear, VertShear, LinVShear, GustSpeed (OpenFAST IfW_UniformWind); InflowWind
interpolates linearly between rows and holds the end rows outside them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from turbgen.version import __version__
from turbgen.exporters.inflowwind_file import InflowWindInput, inflowwind_path, write_inflowwind
from turbgen.exporters.outputs import OutputSet
from turbgen.spec.iec_transient import COLUMNS, IecTransient
from turbgen.spec.mean_wind import CW_NOTE

_UNITS = ("s", "m/s", "deg", "m/s", "-", "-", "-", "m/s")


def uniform_text(event: IecTransient) -> str:
    """The uniform wind file of ``event``: ``!`` header lines, then rows of the 8 columns (``%.10g``)."""
    cols = event.columns()
    head = [f"! {event.describe()}",
            f"! written by turbgen {__version__}; RefHt_Uni = hub height {event.hub_height_m:g} m, "
            f"RefLength = rotor diameter {event.rotor_diameter_m:g} m; WindDir positive {CW_NOTE}",
            "! " + " ".join(f"{c}[{u}]" for c, u in zip(COLUMNS, _UNITS))]
    rows = np.column_stack([cols[c] for c in COLUMNS])
    body = [" ".join(f"{v + 0.0:.10g}" for v in row) for row in rows]  # + 0.0: no "-0"
    return "\n".join(head + body) + "\n"


def export_transient(event: IecTransient, out, *, overwrite: bool = False, runner_files: bool = True):
    """Write ``event`` as the uniform wind file ``out`` and, with ``runner_files``, its InflowWind input file: (paths
    written, one usage line per input file)."""
    out = Path(out)
    dat = inflowwind_path(out.with_suffix("") if out.suffix else out, "uniform")
    paths = [out, dat] if runner_files else [out]
    usage = []
    with OutputSet(paths, overwrite=overwrite) as files:
        files.temp(out).write_text(uniform_text(event))
        if runner_files:
            usage.append(write_inflowwind(files, dat, InflowWindInput(
                2, event.hub_height_m, event.V_hub_m_s, {"FileName_Uni": out},
                ref_length_m=event.rotor_diameter_m, title=event.describe())))
    return paths, usage
