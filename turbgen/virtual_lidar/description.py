"""What a lidar is: beams, range gates, probe volume, timing, and the turbine it serves.

Presets (``PRESETS``; docs/lidar.md): ``nacelle-4beam`` (Guo et al. 2023 Table 3), ``spinner-cw`` and
``spinner-pulsed`` (Fu et al. 2023, Eq. 12), ``nacelle-1beam``. A user lidar is a TOML or JSON file with the same
fields (``schemas/lidar.schema.json``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError, check_choice, check_positive, check_range
from turbgen.input_files import LIDAR_FILE, check_input
from turbgen.spec.config import check_mapping, read_config
from turbgen.theory.lidar_geometry import Measurements, los_vectors, nacelle_directions, spinner_directions
from turbgen.theory.lidar_weighting import cw_discrete, pulsed_discrete, rayleigh_length_m

KINDS = ("pulsed", "cw")
MOUNTS = ("nacelle", "spinner")
MAX_MEASUREMENTS = 4096  # beams x gates
# beams per second [Hz]: from a slow scanning lidar (one beam in 1000 s) to a fast CW one; beyond, the scan time
# and the buffer time of the preview are not a lidar's (1e-300 Hz gave a buffer time of 300 digits)
BEAM_RATE_RANGE_HZ = (1e-3, 1e3)


@dataclass(frozen=True)
class LidarDescription:
    """A lidar and the rotor it previews. Angles in degrees, lengths in metres, rates in Hz. ParameterError for a value
    outside its range (the checks below) or more than MAX_MEASUREMENTS beams x gates."""

    name: str
    kind: str  # "pulsed" (Gaussian probe volume, fwhm_m) or "cw" (Lorentzian: wavelength, beam radius, focus distance)
    mount: str  # "nacelle" (azimuth_deg, elevation_deg per beam) or "spinner" (half_cone_deg, scan_deg, tilt_deg)
    ranges_m: tuple[float, ...]  # upstream x of the gates
    beam_rate_hz: float
    rotor_radius_m: float
    azimuth_deg: tuple[float, ...] = ()
    elevation_deg: tuple[float, ...] = ()
    half_cone_deg: float = 0.0
    scan_deg: tuple[float, ...] = ()
    tilt_deg: float = 0.0
    fwhm_m: float = 30.0
    wavelength_m: float = 1.565e-6
    beam_radius_m: float = 0.028
    source: str = field(default="", compare=False)

    def __post_init__(self):
        check_choice("lidar kind", self.kind, KINDS)
        check_choice("lidar mount", self.mount, MOUNTS)
        for name in ("ranges_m", "azimuth_deg", "elevation_deg", "scan_deg"):
            object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))
        if not self.ranges_m:
            raise ParameterError("lidar ranges_m: give at least one range gate")
        for x in self.ranges_m:
            check_range("lidar range (m)", x, 1.0, 5000.0)
        check_range("lidar beam_rate_hz", self.beam_rate_hz, *BEAM_RATE_RANGE_HZ)
        check_range("rotor radius (m)", self.rotor_radius_m, 1.0, 500.0)
        check_range("lidar fwhm_m", self.fwhm_m, 0.1, 1000.0)
        check_range("lidar wavelength_m", self.wavelength_m, 1e-7, 1e-4)
        check_range("lidar beam_radius_m", self.beam_radius_m, 1e-4, 1.0)
        if self.mount == "nacelle":
            if not self.azimuth_deg or len(self.azimuth_deg) != len(self.elevation_deg):
                raise ParameterError("nacelle lidar: azimuth_deg and elevation_deg need one value per beam")
            for a in self.azimuth_deg:
                check_range("lidar azimuth (deg)", a, -80.0, 80.0)
            for e in self.elevation_deg:
                check_range("lidar elevation (deg)", e, -80.0, 80.0)
        else:
            check_range("lidar half_cone_deg", self.half_cone_deg, 0.0, 80.0)
            if not self.scan_deg:
                raise ParameterError("spinner lidar: scan_deg needs at least one scan angle")
            check_range("lidar tilt_deg", self.tilt_deg, -30.0, 30.0)
        if self.n_beams * len(self.ranges_m) > MAX_MEASUREMENTS:
            raise ParameterError(f"lidar: {self.n_beams} beams x {len(self.ranges_m)} gates exceed "
                                 f"{MAX_MEASUREMENTS} measurements")

    @property
    def n_beams(self) -> int:
        """Number of beams (nacelle: azimuths; spinner: scan angles)."""
        return len(self.azimuth_deg) if self.mount == "nacelle" else len(self.scan_deg)

    @property
    def scan_time_s(self) -> float:
        """Time of one full scan, n_beams / beam_rate_hz [s]."""
        return self.n_beams / self.beam_rate_hz

    def directions(self) -> np.ndarray:
        """Unit beam directions d (n_beams, 3) in (x upstream, y, z)."""
        if self.mount == "nacelle":
            return nacelle_directions(self.azimuth_deg, self.elevation_deg)
        return spinner_directions(self.half_cone_deg, self.scan_deg, self.tilt_deg)

    def measurement_points(self) -> Measurements:
        """Every (beam, gate) measurement, beam-major: LOS vector, focus, probe-volume offsets [m] and weights, padded
        with zero weights to a common length; a spinner's focus is at x / cos(half cone) (Fu et al. 2023)."""
        d = self.directions()
        rows = []
        for b in range(self.n_beams):
            for g, x in enumerate(self.ranges_m):
                if self.mount == "nacelle":
                    focus_dist = x / d[b, 0]  # the gate is the plane x: the focus lies on it
                else:
                    focus_dist = x / np.cos(np.radians(self.half_cone_deg))  # Fu et al. 2023: f_d = x / cos(phi)
                if self.kind == "pulsed":
                    s, w = pulsed_discrete(self.fwhm_m)
                else:
                    s, w = cw_discrete(float(rayleigh_length_m(focus_dist, self.wavelength_m, self.beam_radius_m)))
                rows.append((b, g, focus_dist, s, w))
        k = max(r[3].size for r in rows)
        offsets, weights = np.zeros((len(rows), k)), np.zeros((len(rows), k))
        for i, (_, _, _, s, w) in enumerate(rows):  # pad with zero weights (same rows for one kind)
            offsets[i, : s.size], weights[i, : w.size] = s, w
        beam, gate, dist = (np.array([r[j] for r in rows]) for j in range(3))
        direction = d[beam]
        return Measurements(n=los_vectors(direction), focus_m=direction * dist[:, None], direction=direction,
                            offsets_m=offsets, weights=weights, beam=beam, gate=gate)

    def schedule(self, duration_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Times k / beam_rate_hz [s] and beams k mod n_beams, k < duration * rate (ParameterError unless > 0)."""
        k = np.arange(int(np.floor(check_positive("duration (s)", duration_s) * self.beam_rate_hz + 1e-9)))
        return k / self.beam_rate_hz, k % self.n_beams

    def to_attrs(self) -> dict:
        """Every field, JSON-ready (tuples as lists), for a store's attributes or a report."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


def _spinner_scan_deg(rpm: float = 7.56, rate_hz: float = 4.0, n: int = 32) -> tuple[float, ...]:
    """theta_i = (2 pi / 60) Omega i / f_s, i = 1 ... 32 (Fu et al. 2023 Eq. 12), in degrees."""
    return tuple(float(np.degrees(2.0 * np.pi / 60.0 * rpm * i / rate_hz)) for i in range(1, n + 1))


PRESETS: dict[str, LidarDescription] = {
    "nacelle-4beam": LidarDescription(
        name="nacelle-4beam", kind="pulsed", mount="nacelle",
        ranges_m=tuple(50.0 + 13.3 * i for i in range(10)), beam_rate_hz=4.0, rotor_radius_m=63.0,
        azimuth_deg=(14.4, 14.4, -14.4, -14.4), elevation_deg=(14.0, -14.0, -14.0, 14.0), fwhm_m=30.0,
        source="Guo et al. (2023) Table 3; NREL 5 MW rotor"),
    "spinner-cw": LidarDescription(
        name="spinner-cw", kind="cw", mount="spinner", ranges_m=(190.0,), beam_rate_hz=4.0, rotor_radius_m=120.0,
        half_cone_deg=21.0, scan_deg=_spinner_scan_deg(), tilt_deg=6.0,
        source="Fu et al. (2023) CW optimum; IEA 15 MW rotor"),
    "spinner-pulsed": LidarDescription(
        name="spinner-pulsed", kind="pulsed", mount="spinner", ranges_m=(220.0,), beam_rate_hz=4.0,
        rotor_radius_m=120.0, half_cone_deg=18.0, scan_deg=_spinner_scan_deg(), tilt_deg=6.0, fwhm_m=30.0,
        source="Fu et al. (2023) pulsed optimum; IEA 15 MW rotor"),
    "nacelle-1beam": LidarDescription(
        name="nacelle-1beam", kind="pulsed", mount="nacelle", ranges_m=(100.0,), beam_rate_hz=1.0,
        rotor_radius_m=120.0, azimuth_deg=(0.0,), elevation_deg=(0.0,), fwhm_m=30.0,
        source="single pulsed beam along the axis (Fu et al. 2023 nacelle reference); IEA 15 MW rotor"),
}


def lidar_from_mapping(data: dict, where: str = "lidar") -> LidarDescription:
    """A LidarDescription from a mapping checked against schemas/lidar.schema.json (``where`` names it in errors)."""
    data = dict(check_mapping(data, "lidar", where))
    data.setdefault("name", where)
    return LidarDescription(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in data.items()})


def load_lidar(name_or_path) -> LidarDescription:
    """A preset by name, or a TOML/JSON lidar file (named after its stem unless it sets ``name``)."""
    key = str(name_or_path)
    if key in PRESETS:
        return PRESETS[key]
    path = Path(key)
    if path.suffix.lower() not in (".toml", ".json"):
        raise ParameterError(f"lidar {key!r} is neither a preset ({', '.join(PRESETS)}) nor a .toml/.json file")
    check_input(path, LIDAR_FILE)  # a regular file: read_config reads it again (no FIFO, no device, size cap)
    return lidar_from_mapping(read_config(path, "lidar"), where=path.stem)
