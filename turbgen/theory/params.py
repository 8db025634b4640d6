"""Frozen, validated parameter sets of the turbulence models (SI units)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from turbgen.errors import ParameterError, check_choice, check_finite
from turbgen.theory.ranges import check

LIFETIMES = ("guo", "mann")


@dataclass(frozen=True)
class MannParams:
    """Mann (1994) sheared-tensor parameters plus the Guo et al. (2022) evolution lifetime.

    Frozen dataclass, validated on construction against turbgen.theory.ranges.RANGES.

    Parameters
    ----------
    ae : float
        alpha*epsilon^(2/3) [m^(4/3) s^-2], spectral energy level.
    length_scale_m : float
        L [m], length scale of the energy-containing eddies.
    gamma : float
        Gamma [-], shear anisotropy (0 = isotropic).
    lifetime : str, optional
        "guo" (Guo et al. 2023, Eq. 6, default) or "mann" (Eq. 4, hypergeometric).
    factor1 : float, optional
        Small-k slope of the Guo lifetime is -factor1 [-] (default 1; stable preset 0.8).
    factor2 : float, optional
        Large-k slope of the evolution lifetime tau_e is -(2/3) factor2 [-] (default 3.5 = Eq. 15).
    evo_time_s : float or None, optional
        gamma [s], evolution time constant of tau_e (Eq. 15), default 400 s; None = frozen turbulence.

    Raises
    ------
    ParameterError
        If a value is outside its range or ``lifetime`` is not "guo" or "mann".
    """

    ae: float
    length_scale_m: float
    gamma: float
    lifetime: str = "guo"
    factor1: float = 1.0
    factor2: float = 3.5
    evo_time_s: float | None = 400.0

    def __post_init__(self):
        # ranges: turbgen.theory.ranges.RANGES (the one table of allowed parameter values)
        for key in ("ae", "length_scale_m", "gamma", "factor1", "factor2"):
            object.__setattr__(self, key, check(key, getattr(self, key)))
        check_choice("lifetime", self.lifetime, LIFETIMES)
        if self.evo_time_s is not None:
            object.__setattr__(self, "evo_time_s", check("evo_time_s", self.evo_time_s))

    def with_ae(self, ae: float) -> "MannParams":
        """The same parameters with another energy level alpha*eps^(2/3).

        Parameters
        ----------
        ae : float
            alpha*eps^(2/3) [m^(4/3) s^-2].

        Returns
        -------
        MannParams
            A validated copy with ``ae`` replaced.

        Raises
        ------
        ParameterError
            If ``ae`` is outside the allowed range (turbgen.theory.ranges).
        """
        return replace(self, ae=ae)


@dataclass(frozen=True)
class KaimalParams:
    """Kaimal spectra (Guo et al. 2023, Eq. 11) and IEC yz coherence (Eq. 12) parameters.

    Frozen dataclass, validated on construction against turbgen.theory.ranges.RANGES.

    Parameters
    ----------
    sigma_m_s : tuple of float
        (sigma_u, sigma_v, sigma_w) [m/s], standard deviations of the full spectrum.
    length_scales_m : tuple of float
        (L1, L2, L3) [m], Kaimal integral length scales.
    a_yz : float, optional
        Coherence decay constant [-] (IEC: 12).
    lc_m : float, optional
        Coherence scale parameter Lc [m] (IEC: 8.1 Lambda1; default 340.2 m).

    Raises
    ------
    ParameterError
        If ``sigma_m_s`` or ``length_scales_m`` does not hold three values, or a value is outside its range.
    """

    sigma_m_s: tuple[float, float, float]
    length_scales_m: tuple[float, float, float]
    a_yz: float = 12.0
    lc_m: float = 340.2

    def __post_init__(self):
        if len(self.sigma_m_s) != 3 or len(self.length_scales_m) != 3:
            raise ParameterError("sigma_m_s and length_scales_m need three values (u, v, w)")
        # ranges: turbgen.theory.ranges.RANGES (the one table of allowed parameter values)
        object.__setattr__(
            self, "sigma_m_s", tuple(check("sigma_m_s", s, f"sigma_{c} (m/s)") for c, s in zip("uvw", self.sigma_m_s))
        )
        object.__setattr__(
            self,
            "length_scales_m",
            tuple(check("length_scales_m", s, f"L{i + 1} (Kaimal length, m)") for i, s in enumerate(self.length_scales_m)),
        )
        object.__setattr__(self, "a_yz", check("a_yz", self.a_yz))
        object.__setattr__(self, "lc_m", check("lc_m", self.lc_m))


def check_wind_speed(U) -> float:
    """Mean wind speed U [m/s], 0.5 to 100 (turbgen.theory.ranges).

    Parameters
    ----------
    U : float
        Mean wind speed [m/s].

    Returns
    -------
    float
        U [m/s] as float.

    Raises
    ------
    ParameterError
        If ``U`` is not a finite number in [0.5, 100] m/s.
    """
    return check("U_m_s", U)


__all__ = ["MannParams", "KaimalParams", "LIFETIMES", "check_wind_speed", "check_finite"]
