"""Physical plausibility of a store that decodes: attributes within the allowed ranges, values within
AMPLITUDE_RMS times the root mean square its writer recorded.

Why 100 rms: the fields are Gaussian, so the largest of n samples is about sqrt(2 ln n) rms (7.4 for n = 10^12);
100 rms has probability below exp(-5000): corrupted data, not turbulence."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from turbgen.errors import ParameterError, StoreError
from turbgen.store.layout import RMS_ATTR
from turbgen.theory import ranges

AMPLITUDE_RMS = 100.0  # largest plausible |value| / rms (module docstring)


def check_attributes(attrs: Mapping, where: str) -> None:
    """StoreError unless U_m_s, hub_height_m and every parameter turbgen.theory.ranges knows are in range (lists element
    by element; None skipped)."""
    checks = [(key, key, attrs[key]) for key in ("U_m_s", "hub_height_m")]
    params = attrs.get("parameters", {})
    checks += [(f"parameters/{key}", key, value) for key, value in params.items() if key in ranges.RANGES]
    for name, key, value in checks:
        for v in value if isinstance(value, list) else [value]:
            if v is None:
                continue
            try:
                ranges.check(key, v)
            except ParameterError as exc:
                raise StoreError(f"{where}: attribute {name}: {exc}") from None


def spread_warnings(attrs: Mapping) -> list[str]:
    """Warnings for a recorded rms beyond the largest ``sigma_m_s`` of turbgen.theory.ranges (30 m/s): such data decode
    and are consistent (implausible inputs, extreme Mann corners), so ``info`` warns, not refuses."""
    rms = attrs.get(RMS_ATTR)
    if not isinstance(rms, Mapping):
        return []
    hi = ranges.RANGES["sigma_m_s"].hi
    return [f"{c}: rms {float(r):.3g} m/s is implausible for atmospheric turbulence (beyond {hi:g} m/s, the largest "
            "standard deviation a run accepts); check the run's parameters or its constraint data"
            for c, r in rms.items() if not float(r) <= hi]


def amplitude_limits(attrs: Mapping) -> dict[str, tuple[float, str]]:
    """Component -> (largest plausible |value| [m/s], its basis as text): AMPLITUDE_RMS x rms_m_s (else x U_m_s)."""
    rms = attrs.get(RMS_ATTR)
    if isinstance(rms, Mapping):
        return {c: (AMPLITUDE_RMS * float(r), f"{AMPLITUDE_RMS:g} x its rms {float(r):.3g} m/s") for c, r in rms.items()}
    U = float(attrs["U_m_s"])
    basis = f"{AMPLITUDE_RMS:g} x the mean wind {U:g} m/s (a store without {RMS_ATTR})"
    return {c: (AMPLITUDE_RMS * U, basis) for c in ("u", "v", "w")}


def check_amplitudes(block: np.ndarray, component: str, limit: tuple[float, str], where, ix: int, t0: int,
                     chunk_t: int) -> None:
    """StoreError at the first value of ``block`` (plane ``ix`` from time ``t0``) beyond ``limit`` in magnitude."""
    bound, basis = limit
    if block.size == 0 or max(float(block.max()), -float(block.min())) <= bound:
        return
    it, iy, iz = (int(i) for i in np.argwhere(np.abs(block) > bound)[0])
    t = t0 + it
    value = float(block[it, iy, iz])
    shown = f"{value:.3g}" if math.isfinite(value) else str(value)
    raise StoreError(f"{where}: implausible value {shown} m/s at {component}, plane index {ix}, t index {t}, y index "
                     f"{iy}, z index {iz} (beyond {basis}; chunk file {component}/c/{t // chunk_t}/{ix}/0/0); the data "
                     "are corrupted, regenerate the store")
