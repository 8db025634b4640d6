"""IEC 61400-1 Ed. 4 design-load-case sets of turbulent fields (Table 2): DLC 1.1, 1.2 (NTM) and 1.3 (ETM).

Hub speeds V_in .. V_out in 2 m/s steps, 6 seeds each, at the turbine class's I_ref. Each run is the
neutral preset's model shape with its variance set to the load case's sigma1 at V_hub (NTM: Sect.
6.3.2.3; ETM: :func:`turbgen.theory.iec_transients.etm_sigma1_m_s`) by the model's declared ``load_case``
(turbgen.spec.models; e.g. Kaimal's sigma2,3 = 0.8, 0.5 sigma1 and the lengths from Lambda1(hub), Annex C)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError, check_choice, check_int, check_range
from turbgen.spec.iec_transient import parse_class
from turbgen.spec.models import DECLARATIONS, declaration, resolve
from turbgen.spec.preset_runs import run_keys
from turbgen.theory import iec_transients as iec
from turbgen.theory.kaimal import IEC_IREF, iec_sigma1_m_s

DLCS = {"1.1": "NTM", "1.2": "NTM", "1.3": "ETM"}
SPEED_STEP_M_S = 2.0


@dataclass(frozen=True)
class DlcSet:
    """A DLC set (validated at construction; ParameterError otherwise): ``dlc`` "1.1", "1.2" (NTM) or "1.3" (ETM),
    ``iec_class`` e.g. "IIB", cut-in and cut-out hub speeds [m/s] 0.5 <= V_in <= V_out <= V_ref, distinct seeds."""

    dlc: str
    iec_class: str
    v_in_m_s: float = 4.0
    v_out_m_s: float = 24.0
    seeds: tuple = (1, 2, 3, 4, 5, 6)

    def __post_init__(self):
        put = object.__setattr__
        check_choice("DLC", str(self.dlc), tuple(DLCS))
        put(self, "dlc", str(self.dlc))
        turbine, category = parse_class(self.iec_class)
        put(self, "iec_class", turbine + category)
        v_ref = iec.V_REF_M_S[turbine]
        put(self, "v_in_m_s", check_range("V_in (m/s)", self.v_in_m_s, 0.5, v_ref))
        put(self, "v_out_m_s", check_range("V_out (m/s)", self.v_out_m_s, self.v_in_m_s, v_ref))
        seeds = tuple(check_int("seed", s, 0) for s in self.seeds)
        if not seeds or len(set(seeds)) != len(seeds):
            raise ParameterError(f"seeds = {list(seeds)}: give at least one, without duplicates")
        put(self, "seeds", seeds)

    @property
    def category(self) -> str:
        """Turbulence category A+, A, B or C."""
        return parse_class(self.iec_class)[1]

    @property
    def label(self) -> str:
        """Name prefix of the set's runs, e.g. "dlc1.2-IIB"."""
        return f"dlc{self.dlc}-{self.iec_class}"

    def speeds_m_s(self) -> tuple[float, ...]:
        """V_in, V_in + 2, ... below V_out, and V_out [m/s]."""
        n = int(np.floor((self.v_out_m_s - self.v_in_m_s) / SPEED_STEP_M_S + 1e-9))
        speeds = [self.v_in_m_s + SPEED_STEP_M_S * k for k in range(n + 1)]
        if self.v_out_m_s - speeds[-1] > 1e-9:
            speeds.append(self.v_out_m_s)
        return tuple(round(s, 9) for s in speeds)

    def sigma1_m_s(self, V_hub_m_s: float) -> float:
        """The load case's sigma1 [m/s] at V_hub: NTM (1.1, 1.2) or ETM (1.3)."""
        if DLCS[self.dlc] == "NTM":
            return iec_sigma1_m_s(V_hub_m_s, self.category)
        return iec.etm_sigma1_m_s(V_hub_m_s, IEC_IREF[self.category], iec.V_REF_M_S[parse_class(self.iec_class)[0]])

    def run_mapping(self, model: str, V_hub_m_s: float, seed: int) -> dict:
        """The run mapping of one field of ``model`` (one of :func:`dlc_models`) at hub speed ``V_hub_m_s`` [m/s]
        and ``seed``: the neutral preset's keys set to the load case's sigma1 by the model's ``load_case``."""
        check_choice("model", model, dlc_models())
        keys = {**run_keys(model, "neutral", V_hub_m_s), "U_m_s": V_hub_m_s, "seed": seed,
                "turb_class": self.category}
        return resolve(declaration(model).load_case, "spec")(keys, self.sigma1_m_s(V_hub_m_s))


def dlc_models() -> tuple[str, ...]:
    """The declared models with a load-case rule (turbgen.spec.models ``load_case``): the models of DLC sets."""
    return tuple(d.name for d in DECLARATIONS if d.load_case)
