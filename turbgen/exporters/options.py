"""The export options of `turbgen export` and the service, made into one :class:`turbgen.exporters.ExportRequest`."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from turbgen.errors import ParameterError
from turbgen.exporters.request import ExportRequest
from turbgen.spec.mean_wind_files import mean_wind_from_options

RUNNER_FORMATS = ("bts", "wnd", "evo", "hawc2")
TRANSIENTS = ("EOG", "EDC", "ECD", "EWS-V", "EWS-H")


@dataclass(frozen=True)
class ExportOptions:
    """The export options as typed (None: not given), before they are checked (fields as ExportRequest's)."""

    plane: int | None = None
    hub_height_m: float | None = None
    shear_exponent: float | None = None
    profile: str | None = None  # ``power:ALPHA``, ``log:z0=Z0[,d=D]`` or ``table:FILE``
    veer_deg_per_m: float | None = None
    mean_history: str | None = None  # CSV of t, U [, dir]
    transient: str | None = None  # EOG, EDC, ECD, EWS-V or EWS-H with iec_class, rotor_diameter_m [m] and start [s]
    iec_class: str | None = None
    rotor_diameter_m: float | None = None
    transient_start_s: float = 10.0
    transient_sign: str = "+"
    tower: bool = False
    periodic: bool = True
    drop_below_ground: bool = False
    runner_files: bool = True
    overwrite: bool = False

    def given(self) -> dict:
        """The options that differ from their defaults, name -> value (a cache key of the service)."""
        default = asdict(ExportOptions())
        return {k: v for k, v in asdict(self).items() if v != default[k]}


def export_request(store, fmt: str, opts: ExportOptions, *, inline: bool = False,
                   source_label: str | None = None) -> ExportRequest:
    """The ExportRequest of ``opts`` for ``store`` in format ``fmt``; without any mean-wind option, a replayed
    store's fitted mean wind (:func:`fitted_mean_wind`), said in the notes. ``inline``: the profile table and
    history hold rows, not file names (the service).

    Raises
    ------
    ParameterError
        For conflicting or malformed options, values outside their ranges.
    StoreError
        For a transient on a missing or incomplete store.
    """
    profile, shear, veer = opts.profile, opts.shear_exponent, opts.veer_deg_per_m
    notes: tuple = ()
    if fmt in RUNNER_FORMATS and profile is shear is veer is opts.mean_history is None:  # the mean-wind formats
        fitted = fitted_mean_wind(store)
        profile, veer = fitted.get("profile"), fitted.get("veer_deg_per_m")
        if fitted:
            notes = ("mean wind fitted to the store's data (its fit record): "
                     + " ".join(f"--{k.split('_')[0]} {v}" for k, v in fitted.items()) + "; give --profile/--veer to "
                     "override",)
    if shear is not None and profile is not None:
        raise ParameterError(f"--shear-exponent {shear:g} and --profile {profile} both set the profile; give one")
    if shear is not None and (veer is not None or opts.mean_history is not None):
        profile, shear = f"power:{shear!r}", None
    event = _transient(store, opts)
    mean_wind = mean_wind_from_options(profile, veer, opts.mean_history, event, inline=inline)
    return ExportRequest(plane=opts.plane, hub_height_m=opts.hub_height_m, shear_exponent=shear, tower=opts.tower,
                         periodic=opts.periodic, drop_below_ground=opts.drop_below_ground, overwrite=opts.overwrite,
                         source_label=source_label, mean_wind=mean_wind,
                         runner_files=opts.runner_files and fmt in RUNNER_FORMATS, notes=notes)


def fitted_mean_wind(store) -> dict:
    """The export options {"profile", "veer_deg_per_m"} of a replayed store's ``fit`` record; {} for others."""
    from turbgen.store import FieldStore, open_store

    fs = store if isinstance(store, FieldStore) else open_store(store)
    return dict((fs.attrs.get("fit") or {}).get("export") or {})


def _transient(store, opts: ExportOptions):
    """The IEC transient of the options at the store's U and hub height (None without ``transient``)."""
    extra = [n for n, v in (("--iec-class (iec_class)", opts.iec_class),
                            ("--rotor-diameter (rotor_diameter_m)", opts.rotor_diameter_m)) if v is not None]
    if opts.transient is None:
        if extra:
            raise ParameterError(f"{' and '.join(extra)} belong to --transient (transient)")
        return None
    kind = str(opts.transient).upper()
    if kind not in TRANSIENTS:
        raise ParameterError(f"transient {opts.transient!r} is not one of {', '.join(TRANSIENTS)}")
    if opts.iec_class is None or opts.rotor_diameter_m is None:
        raise ParameterError(f"--transient {kind} needs --iec-class and --rotor-diameter (iec_class, rotor_diameter_m)")
    if opts.transient_sign not in ("+", "-"):
        raise ParameterError(f"transient sign {opts.transient_sign!r} is not '+' or '-'")
    from turbgen.spec.iec_transient import IecTransient
    from turbgen.store import FieldStore, open_store

    fs = store if isinstance(store, FieldStore) else open_store(store)
    hub = fs.hub_height_m if opts.hub_height_m is None else opts.hub_height_m
    return IecTransient(kind, opts.iec_class, fs.U_m_s, hub, opts.rotor_diameter_m, start_s=opts.transient_start_s,
                        duration_s=(fs.grid.nt - 1) * fs.grid.dt_s, sign=1 if opts.transient_sign == "+" else -1)
