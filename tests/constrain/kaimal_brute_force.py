"""Independent reference for the Kaimal conditioning tests: the prior covariance of a tiny Kaimal field measured as
the generator's response to unit noise vectors (KaimalEvo is linear in its noise; real and imaginary parts of every
noise value are independent N(0, 1), so the covariance is the sum of the responses' outer products).

Nothing here uses turbgen.synthesis.kaimal_conditioning: the covariance comes from the real synthesis code path
(samplers, float32 amplitudes and longitudinal factors, Nyquist handling, inverse FFT), one noise coordinate at a time.
"""

from __future__ import annotations

import numpy as np

from turbgen.synthesis import kaimal_evo
from turbgen.synthesis.kaimal_evo import COMPONENTS


def generator_covariance(monkeypatch, gen) -> np.ndarray:
    """Covariance (N, N) of the field of ``gen`` flattened as (component, plane, t, y, z), N = 3 nx nt ny nz
    (components are independent: block diagonal)."""
    g = gen.grid
    target = {}
    sizes = {}

    def unit_noise(key, out):
        sizes[key] = out.size
        out[...] = 0
        if target.get("key") == key:
            out.reshape(-1)[target["index"]] = target["value"]
        return out

    monkeypatch.setattr(kaimal_evo, "keyed_complex_normal", unit_noise)
    per_comp = g.nx * g.nt * g.ny * g.nz
    cov = np.zeros((3 * per_comp, 3 * per_comp))
    for c, comp in enumerate(COMPONENTS):
        target.clear()
        list(gen.component_planes(comp))  # records the noise size of every (plane, chunk) key
        keys = [k for k in sizes if k[1] == c]
        responses = []
        for key in keys:
            for index in range(sizes[key]):
                for value in (1.0, 1.0j):
                    target.update(key=key, index=index, value=value)
                    field = np.zeros((g.nx, g.nt, g.ny, g.nz))
                    for ix, plane in gen.component_planes(comp):
                        field[ix] = plane
                    responses.append(field.ravel())
        a = np.array(responses)
        cov[c * per_comp:(c + 1) * per_comp, c * per_comp:(c + 1) * per_comp] = a.T @ a
    return cov
