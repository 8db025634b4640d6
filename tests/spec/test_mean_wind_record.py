"""MeanWind's record (to_attrs -> from_attrs) gives the same mean wind back, and fluctuation_uv undoes full_uv
(the constraints' mean removal is the exports' mean addition run backwards)."""

from __future__ import annotations

import numpy as np
import pytest

from turbgen.errors import ParameterError
from turbgen.spec.iec_transient import IecTransient
from turbgen.spec.mean_wind import MeanWind

WINDS = [
    MeanWind(),
    MeanWind(profile="log", roughness_m=0.03, displacement_m=2.0, veer_deg_per_m=-0.3,
             history_times_s=(0.0, 10.0), history_speeds_m_s=(9.0, 12.0), history_directions_deg=(0.0, 8.0)),
    MeanWind(profile="table", table_heights_m=(50.0, 100.0, 150.0), table_speeds_m_s=(8.0, 10.0, 11.0),
             table_directions_deg=(4.0, 0.0, -5.0), table_label="t.csv"),
    MeanWind(shear_exponent=0.14, transient=IecTransient("ECD", "IIB", 10.0, 100.0, 80.0, start_s=2.0, duration_s=30.0,
                                                         sign=-1)),
]


@pytest.mark.parametrize("wind", WINDS)
def test_record_round_trip(wind):
    assert MeanWind.from_attrs(wind.to_attrs()) == wind


@pytest.mark.parametrize("wind", WINDS)
def test_fluctuation_uv_inverts_full_uv(wind):
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 20.0, 41)[:, None]
    y, h = np.array([-30.0, 0.0, 25.0])[None, :], np.array([60.0, 100.0, 140.0])[None, :]
    u, v = rng.normal(size=(41, 3)), rng.normal(size=(41, 3))
    fu, fv = wind.full_uv(u, v, t, y, h, 10.0, 100.0)
    assert np.abs(fu - u).max() > 1.0  # the mean is really there
    bu, bv = wind.fluctuation_uv(fu, fv, t, y, h, 10.0, 100.0)
    np.testing.assert_allclose(bu, u, rtol=0, atol=1e-12)  # round-off of a rotation and back, of ~10 m/s values
    np.testing.assert_allclose(bv, v, rtol=0, atol=1e-12)


def test_unknown_record_keys_are_refused():
    with pytest.raises(ParameterError, match="unknown keys shear"):
        MeanWind.from_attrs({"profile": "power", "shear": 0.2})
