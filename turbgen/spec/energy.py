"""The Mann energy level alpha*eps^(2/3) of a run, from ae itself, sigma_u, the TI or an IEC class.

One rule, one quadrature, for ``MannRun.from_mapping`` (so every front end) and ``turbgen theory``."""

from __future__ import annotations

from turbgen.errors import check_choice
from turbgen.theory import ranges
from turbgen.theory.kaimal import IEC_IREF, iec_sigma1_m_s
from turbgen.theory.params import MannParams

def resolve_ae(shape: MannParams, U_m_s: float, *, ae: float | None = None, sigma_u_m_s: float | None = None,
               ti: float | None = None, turb_class: str = "A") -> tuple[float, str]:
    """alpha*eps^(2/3) [m^(4/3) s^-2] of a Mann run and a line saying how it was chosen (recorded in the store): the
    first given of ``ae``, ``sigma_u_m_s`` [m/s], ``ti`` [-] (sigma_u = ti U) and ``turb_class`` (NTM
    sigma_1 = Iref (0.75 U + 5.6)) sets it; for a target sigma_u, from ``shape``'s variance (its own ae ignored)."""
    if ae is not None:
        return ranges.check("ae", ae), "ae"
    if sigma_u_m_s is not None:
        sigma = ranges.check("sigma_u_m_s", sigma_u_m_s)
        how = f"sigma_u = {sigma:g} m/s"
    elif ti is not None:
        ti = ranges.check("ti", ti)
        sigma, how = ti * U_m_s, f"ti = {ti:g} (sigma_u = {ti * U_m_s:g} m/s)"
    else:
        check_choice("turb_class", turb_class, tuple(IEC_IREF))
        sigma = iec_sigma1_m_s(U_m_s, turb_class)
        how = f"IEC class {turb_class} NTM sigma_1 = {sigma:.4g} m/s at U"
    from turbgen.theory.mann_spectra import ae_for_sigma_u  # imported on use: scipy quadrature

    return ae_for_sigma_u(sigma, shape), f"model sigma_u: {how}"
