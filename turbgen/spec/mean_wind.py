"""The mean wind an export adds to the stored fluctuations: one frozen, validated definition.

A :class:`MeanWind` is a vertical profile (power law, log law or a table of height -> speed
[, direction]), an optional veer and an optional hub-height time history. Every InflowWind/HAWC2
export applies it the same way: at height h and slice time t,

    U(t, y, h) = U_hub(t) * r(h) + g(t) + s_v(t) (h - h_hub) / D + s_h(t) y / D,
    theta(t, h) = veer(h) + direction(t),
    (u, v) = rotate((U(t, y, h) + u', v'), theta)        (Jonkman 2009, TurbSim's per-height rotation)

with r(h) = U(h)/U(h_hub) (:mod:`turbgen.theory.mean_wind`), U_hub(t) the history's speed (else the store's U), g, s_v,
s_h and the direction of a superimposed IEC transient (:class:`turbgen.spec.iec_transient.IecTransient`), u', v' the
stored fluctuations; w is unchanged. Angles turn counter-clockwise seen from above (CCW_NOTE); an IEC direction,
clockwise in InflowWind, enters with its sign flipped."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError, check_choice, check_finite, check_nonnegative, check_positive, check_range
from turbgen.spec.iec_transient import IecTransient
from turbgen.theory import mean_wind as formulas
from turbgen.theory import ranges

PROFILES = ("power", "log", "table")
DEFAULT_SHEAR_EXPONENT = 0.2
# the two senses of a wind direction, named wherever one is used: turbgen's veer and direction columns turn
# counter-clockwise seen from above; InflowWind's WindDir, PropagationDir and the IEC transients' "+" clockwise
CCW_NOTE = "counter-clockwise seen from above (TurbSim's sense; InflowWind's WindDir is clockwise)"
CW_NOTE = "clockwise seen from above (InflowWind's WindDir sense; --veer and direction columns are counter-clockwise)"
VEER_LIMIT_DEG_PER_M = 5.0  # |rate| beyond this turns the flow by > 90 deg over 18 m: surely a unit mistake
DIRECTION_LIMIT_DEG = 360.0  # a direction column: a compass bearing or an angle relative to the hub, within one turn


def _strictly_increasing(name: str, values) -> tuple:
    vals = tuple(check_finite(name, v) for v in values)
    if len(vals) < 2:
        raise ParameterError(f"{name} has {len(vals)} rows; give at least 2")
    for a, b in zip(vals, vals[1:]):
        if not b > a:
            raise ParameterError(f"{name} must increase strictly: {a:g} is followed by {b:g}")
    return vals


def _column(name: str, values, n: int, lo: float, hi: float) -> tuple:
    """``values`` in [lo, hi], none or ``n`` of them."""
    vals = tuple(check_range(name, v, lo, hi) for v in values)
    if vals and len(vals) != n:
        raise ParameterError(f"{name} has {len(vals)} values for {n} rows")
    return vals


@dataclass(frozen=True)
class MeanWind:
    """Mean-wind profile, veer and hub-height time history (validated at construction). History: linear between its
    times, end values held."""

    profile: str = "power"  # "power", "log" or "table"
    shear_exponent: float = DEFAULT_SHEAR_EXPONENT  # in [-1, 1]
    roughness_m: float | None = None  # > 0
    displacement_m: float = 0.0  # >= 0
    table_heights_m: tuple = ()  # above ground [m], increasing
    table_speeds_m_s: tuple = ()  # [m/s]: only the ratio to hub height counts
    table_directions_deg: tuple = ()  # optional [deg]: veer = direction(h) - direction(hub)
    veer_deg_per_m: float = 0.0  # |rate| <= 5, negative = clockwise with height
    history_times_s: tuple = ()  # increasing times at the turbine [s]
    history_speeds_m_s: tuple = ()
    history_directions_deg: tuple = ()  # optional
    table_label: str = ""  # source file names for descriptions
    history_label: str = ""
    transient: IecTransient | None = None  # on the mean (the store's V_hub and hub height); excludes a history

    def __post_init__(self):
        check_choice("mean-wind profile", self.profile, PROFILES)
        put = object.__setattr__
        put(self, "shear_exponent", check_range("shear exponent", self.shear_exponent, -1.0, 1.0))
        put(self, "displacement_m", check_nonnegative("log-law displacement d (m)", self.displacement_m))
        put(self, "veer_deg_per_m", check_range("veer (deg/m)", self.veer_deg_per_m,
                                                -VEER_LIMIT_DEG_PER_M, VEER_LIMIT_DEG_PER_M))
        if self.profile == "log":
            if self.roughness_m is None:
                raise ParameterError("the log profile needs a roughness length z0 > 0 m")
            put(self, "roughness_m", check_positive("log-law roughness z0 (m)", self.roughness_m))
        elif self.roughness_m is not None or self.displacement_m:
            raise ParameterError(f"roughness z0 and displacement d belong to the log profile, not {self.profile!r}")
        if self.profile == "table":
            self._check_table()
        elif self.table_heights_m or self.table_speeds_m_s or self.table_directions_deg:
            raise ParameterError(f"a height table belongs to the table profile, not {self.profile!r}")
        if self.history_times_s or self.history_speeds_m_s or self.history_directions_deg:
            self._check_columns("mean-history", "the mean history", "history_times_s")
        if self.transient is not None:
            if not isinstance(self.transient, IecTransient):
                raise ParameterError(f"transient = {self.transient!r} is not a turbgen.spec.iec_transient.IecTransient")
            if self.has_history:
                raise ParameterError("a hub-height history and an IEC transient both set the hub's time series; "
                                     "give one")

    def _check_table(self):
        z = self._check_columns("profile table", "the profile table", "table_heights_m")
        if z[0] <= 0.0:
            raise ParameterError(f"profile table height {z[0]:g} m is at or below the ground; heights must be > 0 m")
        if self.table_directions_deg and self.veer_deg_per_m:
            raise ParameterError("give the veer either as a rate or as the table's direction column, not both")

    def _check_columns(self, name: str, whole: str, axis_key: str) -> tuple:
        """Check and store the table's or history's axis ``axis_key``, speeds and directions; return the axis."""
        put = object.__setattr__
        prefix, axis, unit = axis_key.split("_")
        x = _strictly_increasing(f"{name} {axis} ({unit})", getattr(self, axis_key))
        put(self, axis_key, x)
        speeds = _column(f"{name} speeds (m/s)", getattr(self, f"{prefix}_speeds_m_s"), len(x), 0.0,
                         ranges.RANGES["measured_m_s"].hi)  # a plausible wind
        if len(speeds) != len(x):
            raise ParameterError(f"{whole} has {len(x)} {axis} but no speeds")
        put(self, f"{prefix}_speeds_m_s", speeds)
        key = f"{prefix}_directions_deg"
        put(self, key, _column(f"{name} directions (deg)", getattr(self, key), len(x), -DIRECTION_LIMIT_DEG,
                               DIRECTION_LIMIT_DEG))
        return x

    @property
    def has_history(self) -> bool:
        """Whether a hub-height time history is given."""
        return bool(self.history_times_s)

    @property
    def turns(self) -> bool:
        """Whether any angle can be non-zero (veer, table or history directions, EDC/ECD transient)."""
        return bool(self.veer_deg_per_m or self.table_directions_deg or self.history_directions_deg
                    or (self.transient is not None and self.transient.kind in ("EDC", "ECD")))

    @property
    def varies(self) -> bool:
        """Whether the mean changes in time or turns (else u only gets a fixed profile)."""
        return self.has_history or self.turns or self.transient is not None

    def speed_ratio(self, heights_m, hub_height_m: float) -> np.ndarray:
        """Profile ratio U(h) / U(h_hub) [-] at ``heights_m`` [m]; ParameterError for a height (or the hub) outside
        the table or at or below d + z0 of the log law, or a table speed of 0 at hub height."""
        h = np.asarray(heights_m, dtype=float)
        if self.profile == "power":
            return formulas.power_law_ratio(h, hub_height_m, self.shear_exponent)
        if self.profile == "log":
            floor = self.displacement_m + self.roughness_m
            low = min(float(h.min(initial=hub_height_m)), hub_height_m)
            if low <= floor:
                raise ParameterError(f"height {low:g} m is at or below d + z0 = {floor:g} m, where the log law "
                                     "has no positive speed; lower d or z0, or raise the hub height")
            return formulas.log_law_ratio(h, hub_height_m, self.roughness_m, self.displacement_m)
        self._check_covered(h, hub_height_m)
        if np.interp(hub_height_m, self.table_heights_m, self.table_speeds_m_s) <= 0.0:
            raise ParameterError(f"the profile table's speed at hub height {hub_height_m:g} m is 0; it sets the "
                                 "profile's shape relative to the hub")
        return formulas.table_ratio(h, self.table_heights_m, self.table_speeds_m_s, hub_height_m)

    def _check_covered(self, h, hub_height_m):
        lo, hi = self.table_heights_m[0], self.table_heights_m[-1]
        for label, value in (("grid height", float(h.min(initial=hub_height_m))),
                             ("grid height", float(h.max(initial=hub_height_m))), ("hub height", hub_height_m)):
            if not lo <= value <= hi:
                raise ParameterError(f"{label} {value:g} m is outside the profile table's heights [{lo:g}, {hi:g}] m")

    def veer_deg(self, heights_m, hub_height_m: float) -> np.ndarray:
        """Veer angle theta(h) [deg] at ``heights_m`` [m], 0 at the hub (inside the table when it gives directions)."""
        h = np.asarray(heights_m, dtype=float)
        if self.table_directions_deg:
            self._check_covered(h, hub_height_m)
            d = np.interp(h, self.table_heights_m, self.table_directions_deg)
            return d - np.interp(hub_height_m, self.table_heights_m, self.table_directions_deg)
        return formulas.linear_veer_deg(h, hub_height_m, self.veer_deg_per_m)

    def hub_history(self, times_s, U_m_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Hub speed [m/s] and direction [deg] at ``times_s`` [s] at the turbine: the history's, else ``U_m_s`` with
        0 or a transient's direction."""
        t = np.asarray(times_s, dtype=float)
        if not self.has_history:
            turn = np.zeros(t.shape) if self.transient is None else -self.transient.at(t)["direction_deg"]
            return np.full(t.shape, float(U_m_s)), turn
        speed = np.interp(t, self.history_times_s, self.history_speeds_m_s)
        direction = (np.interp(t, self.history_times_s, self.history_directions_deg)
                     if self.history_directions_deg else np.zeros(t.shape))
        return speed, direction

    def _added(self, t, y_m, h, U_m_s: float, hub_height_m: float):
        """(U_hub(t) r(h), g + s_v (h - h_hub) / D + s_h y / D) [m/s] and the turn [deg] of the module's formula."""
        speed, turn = self.hub_history(t, U_m_s)
        if self.transient is None:
            gust = vshear = hshear = np.zeros(t.shape)
            diameter = 1.0
        else:  # the transient's gust and shear changes across D
            ev, diameter = self.transient.at(t), self.transient.rotor_diameter_m
            gust, vshear, hshear = ev["gust_m_s"], ev["vshear_m_s"], ev["hshear_m_s"]
        shift = gust + vshear * (h - hub_height_m) / diameter + hshear * np.asarray(y_m, dtype=float) / diameter
        return speed * self.speed_ratio(h, hub_height_m), shift, turn

    def full_uv(self, u, v, times_s, y_m, heights_m, U_m_s: float, hub_height_m: float):
        """Full (u, v) [m/s] from fluctuations by the module's formula (v unchanged without a turn), at turbine time
        [s], y [m] (+y left) and height above ground [m] (broadcast with u), the store's U [m/s] and hub height [m]."""
        h = np.asarray(heights_m, dtype=float)
        profile, shift, turn = self._added(np.asarray(times_s, dtype=float), y_m, h, U_m_s, hub_height_m)
        u = u + profile + shift
        if not self.turns:
            return u, v
        return formulas.rotate_horizontal(u, v, self.veer_deg(h, hub_height_m) + turn)

    def fluctuation_uv(self, u, v, times_s, y_m, heights_m, U_m_s: float, hub_height_m: float):
        """Fluctuations (u', v') [m/s] from total (u, v): the inverse of :meth:`full_uv` (``v`` may be None when the
        mean wind does not turn)."""
        h = np.asarray(heights_m, dtype=float)
        profile, shift, turn = self._added(np.asarray(times_s, dtype=float), y_m, h, U_m_s, hub_height_m)
        if self.turns:
            u, v = formulas.rotate_horizontal(u, v, -(self.veer_deg(h, hub_height_m) + turn))
        return u - profile - shift, v

    def check_record(self, first_s: float, last_s: float) -> None:
        """Refuse (ParameterError) a history or transient with times outside [first_s, last_s] [s], the times at
        which the first and last file slices reach the turbine."""
        spans = []
        if self.transient is not None:
            t0, t1 = self.transient.start_s, self.transient.start_s + self.transient.period_s
            spans.append((t0, t1, f"the {self.transient.kind} from {t0:g} to {t1:g} s is"))
        if self.has_history:
            t0, t1 = self.history_times_s[0], self.history_times_s[-1]
            spans.append((t0, t1, f"mean-history times [{t0:g}, {t1:g}] s are"))
        for t0, t1, what in spans:
            if t0 < first_s - 1e-9 or t1 > last_s + 1e-9:
                raise ParameterError(f"{what} outside the record [{first_s:g}, {last_s:g}] s seen at the turbine")

    def describe(self) -> str:
        """One short line: profile, veer, history, transient (the .bts description, the .sum title, `turbgen info`);
        a transient's direction change is named clockwise, InflowWind's sense."""
        if self.profile == "power":
            out = [f"power-law shear alpha = {self.shear_exponent:g}"]
        elif self.profile == "log":
            out = [f"log law z0 = {self.roughness_m:g} m, d = {self.displacement_m:g} m"]
        else:
            out = [f"profile table {self.table_label} ({len(self.table_heights_m)} heights)".replace("  ", " ")]
        if self.veer_deg_per_m:
            out.append(f"veer {self.veer_deg_per_m:g} deg/m")
        elif self.table_directions_deg:
            out.append("veer from the table")
        if self.has_history:
            out.append(f"hub history {self.history_label} ({len(self.history_times_s)} points)".replace("  ", " "))
        if self.veer_deg_per_m or self.table_directions_deg or self.history_directions_deg:
            out.append("angles ccw from above")  # the written files name the sense (CCW_NOTE)
        if self.transient is not None:
            t = self.transient
            turn = t.kind in ("EDC", "ECD")
            out.append(f"IEC {t.kind} {t.iec_class} ({t.magnitude():.4g} {'deg' if turn else 'm/s'}"
                       f"{'' if t.kind == 'EOG' else f', sign {t.sign:+d}'}{' = cw from above' if turn else ''}) "
                       f"from {t.start_s:g} s")
        return "; ".join(out)

    def to_attrs(self) -> dict:
        """JSON-ready attributes (units in the key names) of the fields that apply, lists for the tables."""
        out = {"profile": self.profile}
        skip = {"profile": True, "displacement_m": self.profile != "log", "shear_exponent": self.profile != "power",
                "veer_deg_per_m": not self.veer_deg_per_m}
        for key, value in self.__dict__.items():
            if skip.get(key) or value in ((), "", None):
                continue
            if key == "transient":
                value = {f: getattr(value, f) for f in ("kind", "iec_class", "V_hub_m_s", "hub_height_m",
                                                         "rotor_diameter_m", "start_s", "duration_s", "sign")}
            out[key] = list(value) if isinstance(value, tuple) else value
        return out

    @classmethod
    def from_attrs(cls, attrs: dict) -> "MeanWind":
        """The MeanWind of :meth:`to_attrs` output (validated again; ParameterError for unknown keys)."""
        fields = dict(attrs)
        unknown = sorted(set(fields) - set(cls.__dataclass_fields__))
        if unknown:
            raise ParameterError(f"mean-wind record has unknown keys {', '.join(unknown)}")
        if fields.get("transient") is not None:
            fields["transient"] = IecTransient(**fields["transient"])
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()})
