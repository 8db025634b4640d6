"""Frozen, validated parameter sets of the turbulence models (SI units)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from turbgen.errors import ParameterError, check_choice, check_finite
from turbgen.theory.ranges import check

LIFETIMES = ("guo", "mann")


@dataclass(frozen=True)
class MannParams:
    """Mann (1994) sheared-tensor parameters plus the Guo et al. (2022) evolution lifetime.

    Validated against turbgen.theory.ranges (ParameterError, also for an unknown ``lifetime``).

    Parameters
    ----------
    ae, length_scale_m, gamma : float
        alpha*epsilon^(2/3) [m^(4/3) s^-2], spectral energy level; L [m], length scale of the energy-containing
        eddies; Gamma [-], shear anisotropy (0 = isotropic).
    lifetime, factor1, factor2, evo_time_s : str, float, float, float or None, optional
        "guo" (Guo et al. 2023, Eq. 6) or "mann" (Eq. 4, hypergeometric); slopes [-]: Guo lifetime's small-k
        -factor1 (stable 0.8), evolution's large-k -(2/3) factor2 (Eq. 15: 3.5); gamma [s], time constant of
        tau_e (Eq. 15), None = frozen turbulence.
    """

    ae: float
    length_scale_m: float
    gamma: float
    lifetime: str = "guo"
    factor1: float = 1.0
    factor2: float = 3.5
    evo_time_s: float | None = 400.0

    def __post_init__(self):
        for key in ("ae", "length_scale_m", "gamma", "factor1", "factor2"):
            object.__setattr__(self, key, check(key, getattr(self, key)))
        check_choice("lifetime", self.lifetime, LIFETIMES)
        if self.evo_time_s is not None:
            object.__setattr__(self, "evo_time_s", check("evo_time_s", self.evo_time_s))

    def with_ae(self, ae: float) -> "MannParams":
        """A validated copy with the energy level ``ae`` [m^(4/3) s^-2] replaced."""
        return replace(self, ae=ae)


@dataclass(frozen=True)
class KaimalParams:
    """Kaimal spectra (Guo et al. 2023, Eq. 11) and IEC yz coherence (Eq. 12) parameters.

    Validated against turbgen.theory.ranges (ParameterError, also unless the tuples hold three values).

    Parameters
    ----------
    sigma_m_s, length_scales_m : tuple of float
        (sigma_u, sigma_v, sigma_w) [m/s]; (L1, L2, L3) [m], Kaimal integral length scales.
    a_yz, lc_m : float, optional
        Coherence decay constant [-] (IEC: 12) and scale parameter Lc [m] (IEC: 8.1 Lambda1).
    """

    sigma_m_s: tuple[float, float, float]
    length_scales_m: tuple[float, float, float]
    a_yz: float = 12.0
    lc_m: float = 340.2

    def __post_init__(self):
        if len(self.sigma_m_s) != 3 or len(self.length_scales_m) != 3:
            raise ParameterError("sigma_m_s and length_scales_m need three values (u, v, w)")
        object.__setattr__(
            self, "sigma_m_s", tuple(check("sigma_m_s", s, f"sigma_{c} (m/s)") for c, s in zip("uvw", self.sigma_m_s))
        )
        object.__setattr__(
            self,
            "length_scales_m",
            tuple(check("length_scales_m", s, f"L{i + 1} (Kaimal length, m)") for i, s in enumerate(self.length_scales_m)),
        )
        for key in ("a_yz", "lc_m"):
            object.__setattr__(self, key, check(key, getattr(self, key)))


def check_wind_speed(U) -> float:
    """Mean wind speed ``U`` [m/s] as float, or ParameterError outside its range (turbgen.theory.ranges)."""
    return check("U_m_s", U)


__all__ = ["MannParams", "KaimalParams", "LIFETIMES", "check_wind_speed", "check_finite"]
