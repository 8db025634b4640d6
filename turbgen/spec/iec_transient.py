"""An IEC 61400-1 Ed. 4 deterministic transient (EOG, EDC, ECD, EWS) from the turbine class and V_hub.

Written as the columns of an InflowWind uniform wind file (WindType 2, what IECWind writes), whose
horizontal speed at (X, Y, Z) and t is (OpenFAST IfW_UniformWind; Delta clockwise seen from above)
V_h = V (Z/RefHt)^VShr + V HLinShr/RefLength (Y cos Delta + X sin Delta) + V VLinShr/RefLength (Z - RefHt) + VGust;
with V = V_hub, VShr = 0.2 (the normal wind profile), the EOG and ECD speed changes in VGust, the EDC
and ECD direction in Delta and the EWS shear in VLinShr or HLinShr with RefLength = D, V_h is the
standard's formula exactly at every row."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError, check_choice, check_positive, check_range
from turbgen.theory import iec_transients as iec
from turbgen.theory.kaimal import iec_lambda1_m, iec_sigma1_m_s

KINDS = ("EOG", "EDC", "ECD", "EWS-V", "EWS-H")
PERIODS_S = {"EOG": iec.EOG_PERIOD_S, "EDC": iec.EDC_PERIOD_S, "ECD": iec.ECD_PERIOD_S,
             "EWS-V": iec.EWS_PERIOD_S, "EWS-H": iec.EWS_PERIOD_S}
COLUMNS = ("Time", "WindSpeed", "WindDir", "VertSpeed", "HorizShear", "VertShear", "LinVShear", "GustSpeed")
NWP_EXPONENT = 0.2  # normal wind profile exponent (Sect. 6.3.2.2)


def parse_class(text: str) -> tuple[str, str]:
    """("II", "B") from "IIB" (also "IA+", "III C"): turbine class I/II/III and turbulence category A+/A/B/C;
    ParameterError for anything else."""
    m = re.fullmatch(r"\s*(III|II|I)\s*(A\+|A|B|C)\s*", str(text).upper())
    if not m:
        raise ParameterError(f"IEC class {text!r} is not I, II or III followed by A+, A, B or C (e.g. IIB)")
    return m.group(1), m.group(2)


MIN_DT_S = 0.001  # finest row spacing [s], as the fields' --dt

@dataclass(frozen=True)
class IecTransient:
    """One IEC event at hub speed V_hub, validated at construction (ParameterError otherwise)."""

    kind: str  # "EOG", "EDC", "ECD", "EWS-V" or "EWS-H"
    iec_class: str  # e.g. "IIB"
    V_hub_m_s: float  # [m/s] in (0, V_ref] (below V_e1 = 1.12 V_ref the EOG gust is positive)
    hub_height_m: float  # [m]; the rotor clear of the ground
    rotor_diameter_m: float  # D [m]
    start_s: float = 10.0  # [s]; the event ends within the file
    duration_s: float = 60.0  # [s]
    dt_s: float = 0.05  # row spacing during the event [s] in [MIN_DT_S, T/4]
    sign: int = 1  # +1 or -1, the standard's "+-" (direction change or shear sense), EOG +1 only

    def __post_init__(self):
        put = object.__setattr__
        put(self, "kind", check_choice("transient", str(self.kind).upper(), KINDS))
        turbine, category = parse_class(self.iec_class)
        put(self, "iec_class", turbine + category)
        put(self, "V_hub_m_s", check_range("V_hub (m/s)", self.V_hub_m_s, 0.0, iec.V_REF_M_S[turbine], lo_open=True))
        put(self, "hub_height_m", check_positive("hub height (m)", self.hub_height_m))
        put(self, "rotor_diameter_m", check_positive("rotor diameter (m)", self.rotor_diameter_m))
        if self.rotor_diameter_m / 2 >= self.hub_height_m:
            raise ParameterError(f"rotor diameter {self.rotor_diameter_m:g} m reaches the ground at hub height "
                                 f"{self.hub_height_m:g} m")
        put(self, "duration_s", check_positive("duration (s)", self.duration_s))
        period = PERIODS_S[self.kind]
        # at least MIN_DT_S: the rows are allocated and written
        put(self, "dt_s", check_range("dt (s)", self.dt_s, MIN_DT_S, period / 4))
        put(self, "start_s", check_range("transient start (s)", self.start_s, 0.0, self.duration_s))
        if self.start_s + period > self.duration_s:
            raise ParameterError(f"the {self.kind} ({period:g} s) starting at {self.start_s:g} s ends at "
                                 f"{self.start_s + period:g} s, outside the record of {self.duration_s:g} s")
        if self.sign not in (1, -1) or (self.kind == "EOG" and self.sign != 1):
            raise ParameterError(f"sign = {self.sign!r} must be +1 or -1 (EOG: +1)")

    @property
    def category(self) -> str:
        """Turbulence category A+, A, B or C."""
        return parse_class(self.iec_class)[1]

    @property
    def period_s(self) -> float:
        """Duration T of the event [s]."""
        return PERIODS_S[self.kind]

    @property
    def sigma1_m_s(self) -> float:
        """NTM sigma1 = I_ref (0.75 V_hub + 5.6) [m/s]."""
        return iec_sigma1_m_s(self.V_hub_m_s, self.category)

    @property
    def lambda1_m(self) -> float:
        """Longitudinal turbulence scale parameter Lambda1 [m]."""
        return iec_lambda1_m(self.hub_height_m)

    def magnitude(self) -> float:
        """The event's size: V_gust [m/s] (EOG), theta_e or theta_cg [deg] (EDC, ECD), the EWS amplitude [m/s]."""
        if self.kind == "EOG":  # with the turbine class's 1-year extreme gust V_e1
            v_e1 = iec.extreme_speeds_m_s(iec.V_REF_M_S[parse_class(self.iec_class)[0]])[1]
            return iec.eog_gust_m_s(self.V_hub_m_s, v_e1, self.sigma1_m_s, self.rotor_diameter_m, self.lambda1_m)
        if self.kind == "EDC":
            return iec.edc_angle_deg(self.V_hub_m_s, self.sigma1_m_s, self.rotor_diameter_m, self.lambda1_m)
        if self.kind == "ECD":
            return iec.ecd_angle_deg(self.V_hub_m_s)
        return iec.ews_amplitude_m_s(self.sigma1_m_s, self.rotor_diameter_m, self.lambda1_m)

    def times_s(self) -> np.ndarray:
        """Row times [s]: 0, the event sampled every dt (start to start + T), and the end of the record."""
        period = PERIODS_S[self.kind]
        n = int(np.ceil(period / self.dt_s - 1e-9))
        event = self.start_s + np.linspace(0.0, period, n + 1)
        return np.unique(np.concatenate([[0.0], event, [self.duration_s]]))

    def at(self, t_s) -> dict:
        """The event at times ``t_s`` [s] of the record (the event's clock is t - start), zero where it has none:
        "gust_m_s": speed change uniform over the rotor [m/s] (EOG, ECD); "direction_deg": clockwise seen from above, as
        InflowWind (EDC, ECD); "vshear_m_s", "hshear_m_s": speed change across D, times (z - z_hub) / D or y / D (EWS-V,
        EWS-H)."""
        tau = np.asarray(t_s, dtype=float) - self.start_s
        zero = np.zeros_like(tau)
        out = {"gust_m_s": zero, "direction_deg": zero, "vshear_m_s": zero, "hshear_m_s": zero}
        size, period = self.magnitude(), PERIODS_S[self.kind]
        if self.kind == "EOG":
            out["gust_m_s"] = iec.eog_speed_change_m_s(tau, size, period)
        elif self.kind == "EDC":
            out["direction_deg"] = iec.cosine_rise(tau, self.sign * size, period)
        elif self.kind == "ECD":
            out["gust_m_s"] = iec.cosine_rise(tau, iec.ECD_GUST_M_S, period)
            out["direction_deg"] = iec.cosine_rise(tau, self.sign * size, period)
        else:
            out["vshear_m_s" if self.kind == "EWS-V" else "hshear_m_s"] = self.sign * size * iec.ews_factor(tau, period)
        return out

    def columns(self) -> dict:
        """The uniform-wind columns (keys ``COLUMNS``) at :meth:`times_s`, in s, m/s, deg, m/s, -, -, -, m/s (EWS
        shear: LinVShear / HorizShear = (speed change across D) / V_hub with RefLength = D)."""
        t = self.times_s()
        ev = self.at(t)
        return dict(zip(COLUMNS, (t, np.full_like(t, self.V_hub_m_s), ev["direction_deg"], np.zeros_like(t),
                                  ev["hshear_m_s"] / self.V_hub_m_s, np.full_like(t, NWP_EXPONENT),
                                  ev["vshear_m_s"] / self.V_hub_m_s, ev["gust_m_s"])))

    def describe(self) -> str:
        """One line: kind, class, V_hub, magnitude and timing."""
        unit = "deg" if self.kind in ("EDC", "ECD") else "m/s"
        sign = "" if self.kind == "EOG" else f", sign {self.sign:+d}"
        return (f"IEC 61400-1 Ed. 4 {self.kind}, class {self.iec_class}, V_hub {self.V_hub_m_s:g} m/s, "
                f"magnitude {self.magnitude():.6g} {unit}{sign}, from {self.start_s:g} s to "
                f"{self.start_s + PERIODS_S[self.kind]:g} s of {self.duration_s:g} s")
