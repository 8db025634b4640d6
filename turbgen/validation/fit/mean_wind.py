"""The mean wind of total-wind sensor data: power-law exponent, log-law roughness, veer and turbulence intensity.

Per sensor: the time means ū, v̄ [m/s], the speed U = |(ū, v̄)|, the direction atan2(v̄, ū) [deg, counter-clockwise
seen from above, as ``turbgen export --veer``] and σ_u of the along-wind series. Across heights h, least-squares lines
through the sensors' means: the power law ln U = ln U_ref + α ln(h / h_ref); the log law U = (u*/κ) (ln h - ln z0),
z0 = exp(-b / a) of slope a and intercept b; the veer [deg/m], the slope of the direction against h. The turbulence
intensity σ_u / U is that of the sensor nearest the hub (else the median height; heights unknown: the first sensor).

Intervals: batch means (Flegal & Jones 2010): each estimate is made again from each of BLOCKS blocks' means; its
standard error is the blocks' sd / sqrt(BLOCKS), the interval ± t_0.975(BLOCKS - 1) of it. One mast's turbulence
moves all its sensors' means together (the large eddies span the heights), which the scatter about the line misses."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

BLOCKS = 8  # batch-means blocks of the variance estimate (each block >> the integral time scale)
T95 = float(stats.t.ppf(0.975, BLOCKS - 1))  # the interval's half-width in standard errors
NAMES = ("shear_exponent", "z0_m", "veer_deg_per_m", "turbulence_intensity")


@dataclass(frozen=True)
class MeanWindValue:
    """A mean-wind estimate: ``value`` and ``ci95`` (None: not identified or no interval, ``reason`` says why)."""

    value: float | None
    ci95: tuple | None = None
    reason: str | None = None

    def to_dict(self) -> dict:
        return {"value": self.value, "ci95": None if self.ci95 is None else list(self.ci95), "reason": self.reason}


@dataclass(frozen=True)
class MeanWindFit:
    """The four estimates (module docstring), each a MeanWindValue, ``ti_sensor`` (the sensor of the turbulence
    intensity) and ``U_hub_m_s`` [m/s] (the power law's speed at the hub height; None without one)."""

    shear_exponent: MeanWindValue
    z0_m: MeanWindValue
    veer_deg_per_m: MeanWindValue
    turbulence_intensity: MeanWindValue
    ti_sensor: str = ""
    U_hub_m_s: float | None = None

    def to_dict(self) -> dict:
        out = {n: getattr(self, n).to_dict() for n in NAMES}
        out["turbulence_intensity"]["sensor"] = self.ti_sensor
        return out

    def export_options(self) -> dict:
        """``turbgen export`` options of the fitted profile and veer: {"profile": "power:ALPHA", "veer_deg_per_m":
        ..} (the keys of what was identified)."""
        out = {}
        if self.shear_exponent.value is not None:
            out["profile"] = f"power:{self.shear_exponent.value:.6g}"
        if self.veer_deg_per_m.value is not None:
            out["veer_deg_per_m"] = float(f"{self.veer_deg_per_m.value:.6g}")
        return out

    def lines(self) -> list[str]:
        """Terminal lines, one per estimate."""
        out = []
        for n, unit in zip(NAMES, ("-", "m", "deg/m", "-")):
            v = getattr(self, n)
            val = "not identified" if v.value is None else f"{v.value:10.4g} {unit:5s}"
            ci = f" 95 % interval [{v.ci95[0]:.4g}, {v.ci95[1]:.4g}]" if v.ci95 is not None else ""
            why = v.reason or (self.ti_sensor if n == "turbulence_intensity" else "")
            out.append(f"{n:>20s} = {val}{ci}{f' ({why})' if why else ''}")
        return out


def _none(reason: str) -> MeanWindFit:
    return MeanWindFit(*(MeanWindValue(None, None, reason) for _ in NAMES))


def _slope(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(slope, intercept) of the least-squares line through (x, y); NaN without two distinct x."""
    if len(np.unique(x)) < 2:
        return math.nan, math.nan
    a, b = np.polyfit(x, y, 1)
    return float(a), float(b)


def _profile(h: np.ndarray, ub: np.ndarray, vb: np.ndarray, href: float) -> np.ndarray:
    """(alpha, ln z0, veer [deg/m], ln U(href)) of the sensors' heights and mean u, v (NaN v: no v)."""
    speed = np.hypot(ub, np.nan_to_num(vb))
    alpha, ln_uref = _slope(np.log(h / href), np.log(speed))
    a, b = _slope(np.log(h), speed)
    has_v = np.isfinite(vb)
    veer = _slope(h[has_v], np.degrees(np.arctan2(vb[has_v], ub[has_v])))[0]
    return np.array([alpha, -b / a if a > 0 else math.nan, veer, ln_uref])


def _means(series: list, parts: int) -> np.ndarray:
    """(parts, sensors) time means of each of ``parts`` consecutive blocks (NaN: the sensor has no such series)."""
    nan = np.full(parts, math.nan)
    return np.array([nan if x is None else [np.nanmean(b) for b in np.array_split(x, parts)] for x in series]).T


def fit_mean_wind(ps, hub_height_m: float | None = None) -> MeanWindFit:
    """The mean wind of the point-series file ``ps`` (turbgen.spec.constraints.PointSeries, None for a field; module
    docstring); ``hub_height_m`` [m] places sensors given by z_m (relative to the hub) and picks the sensor of the
    turbulence intensity; sensors given by height_m need none."""
    if ps is None or not ps.total_wind:
        return _none("no total-wind sensor data (a field, or fluctuations): no mean wind")
    sensors = [s for s in ps.sensors if "u" in s.series]
    if not sensors:
        return _none("no sensor measures u")
    h = np.array([s.height_m if s.height_m is not None else math.nan if hub_height_m is None else
                  hub_height_m + s.z_m for s in sensors], dtype=float)
    u = [s.series["u"] for s in sensors]
    v = [s.series.get("v") for s in sensors]
    ti, ti_sensor = _intensity(sensors, h, hub_height_m)
    known = np.isfinite(h)
    if len(np.unique(h[known])) < 2:
        why = ("sensors given relative to the hub (z_m) without a hub height" if not known.any() else
               "one height") + ": the profile and veer are not identified"
        return MeanWindFit(*(MeanWindValue(None, None, why) for _ in NAMES[:3]), ti, ti_sensor)
    href = hub_height_m if hub_height_m is not None else float(np.exp(np.mean(np.log(h[known]))))
    pick = lambda m: _profile(h[known], m[0][known], m[1][known], href)  # noqa: E731
    full = pick((_means(u, 1)[0], _means(v, 1)[0]))
    blocks = np.array([pick(m) for m in zip(_means(u, BLOCKS), _means(v, BLOCKS))])
    sd = np.std(blocks, axis=0, ddof=1) / math.sqrt(BLOCKS)
    reasons = (None, "the mean speed does not increase with height: no log law",
               "fewer than two heights with u and v: veer not identified")
    out = []
    for k, transform in enumerate((float, math.exp, float)):
        if not math.isfinite(full[k]):
            out.append(MeanWindValue(None, None, reasons[k]))
        elif not math.isfinite(sd[k]):
            out.append(MeanWindValue(transform(full[k]), None, "not identified in every block: no interval"))
        else:
            out.append(MeanWindValue(transform(full[k]), (transform(full[k] - T95 * sd[k]),
                                                          transform(full[k] + T95 * sd[k]))))
    hub_u = float(math.exp(full[3])) if hub_height_m is not None else None
    return MeanWindFit(*out, ti, ti_sensor, hub_u)


def mean_direction_deg(u, v) -> float:
    """The direction atan2(v̄, ū) [deg, counter-clockwise seen from above] of the series' means (NaN skipped)."""
    return math.degrees(math.atan2(np.nanmean(v), np.nanmean(u)))


def hub_direction_deg(ps, hub_height_m: float) -> float:
    """The mean wind direction [deg, counter-clockwise seen from above] at ``hub_height_m`` [m] of the total-wind
    sensors of ``ps`` holding u and v: their directions' least-squares line against height there (one height:
    their mean); 0 without such sensors."""
    sensors = [s for s in ps.sensors if {"u", "v"} <= s.series.keys()] if ps.total_wind else []
    if not sensors:
        return 0.0
    h = np.array([s.height_m if s.height_m is not None else hub_height_m + s.z_m for s in sensors], dtype=float)
    d = np.array([mean_direction_deg(s.series["u"], s.series["v"]) for s in sensors])
    slope, intercept = _slope(h, d)
    return float(np.mean(d)) if math.isnan(slope) else slope * hub_height_m + intercept


def _intensity(sensors: list, h: np.ndarray, hub_height_m: float | None) -> tuple[MeanWindValue, str]:
    """sigma_u / U of the sensor nearest the hub (or the median height), interval from batch means; the sensor."""
    known = np.isfinite(h)
    target = hub_height_m if hub_height_m is not None else float(np.median(h[known])) if known.any() else 0.0
    k = int(np.argmin(np.where(known, np.abs(h - target), np.inf))) if known.any() else 0
    s = sensors[k]
    u, v = s.series["u"], s.series.get("v")
    theta = math.atan2(np.nanmean(v), np.nanmean(u)) if v is not None else 0.0
    along = u * math.cos(theta) + (0.0 if v is None else v * math.sin(theta))
    U = float(np.nanmean(along))
    dev2 = (along - U) ** 2
    blocks = np.array([np.nanmean(b) for b in np.array_split(dev2, BLOCKS)])
    var, sd_var = float(np.nanmean(dev2)), float(np.std(blocks, ddof=1) / math.sqrt(BLOCKS))
    ti, sd = math.sqrt(var) / U, sd_var / (2 * math.sqrt(var) * U)  # d(sqrt var)/d var = 1 / (2 sigma)
    return MeanWindValue(ti, (ti - T95 * sd, ti + T95 * sd)), s.name + (f" at {h[k]:g} m" if known[k] else "")
