"""What the validator predicts, and on which sampling design: :class:`Theory` and :class:`SamplingDesign`.

A field is described by the two-sided line variances L_j = E|Z_j|^2 [m^2 s^-2] of x(t) = sum_j Z_j exp(i 2 pi f_j t),
f_j = j / (nt dt) (one-sided variance of a line pair: 2 L_j; turbgen.theory.lattice), and by the line
cross-covariances E[conj(Z_j^a) Z_j^b] between two points or components. ``Theory.rho_*`` hold, for every averaged
point set, the two-frequency correlation sums R(nu_i, nu_j) at the nodes ``node_f`` (``pair_sums``), from which
``welch_variance`` computes the exact covariance of averaged estimates."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from turbgen.grid import Grid
from turbgen.theory.lattice import pair_weights
from turbgen.validation.estimators import Estimates, WelchSetup

N_RHO_NODES = 24  # frequency nodes of the correlation sums rho_bar


@dataclass(frozen=True, eq=False)
class SamplingDesign:
    """Where and how the estimates were taken: the store's ``grid``, the Welch ``setup``, yz ``separations`` (a, b)
    [grid steps], the (ny, nz) ``rotor_mask`` and the plane-pair sub-lattice ``long_iy``, ``long_iz``."""

    grid: Grid
    setup: WelchSetup
    separations: tuple[tuple[int, int], ...]
    rotor_mask: np.ndarray
    long_iy: np.ndarray
    long_iz: np.ndarray

    @classmethod
    def of(cls, est: Estimates) -> SamplingDesign:
        """The design of the estimates ``est``."""
        return cls(est.grid, est.setup, est.separations, est.rotor_mask, est.long_iy, est.long_iz)

    def node_freqs(self) -> np.ndarray:
        """rho_bar nodes [Hz] from the lowest record line 1/(nt dt) (the variance needs it) to the Nyquist frequency."""
        return np.geomspace(1.0 / (self.grid.nt * self.setup.dt_s), self.setup.freqs[-1], N_RHO_NODES)

    def band(self, U_m_s: float) -> dict:
        """What the record and the Welch segments resolve: frequencies [Hz] and k1 = 2 pi f / U [rad/m]."""
        setup, grid, U = self.setup, self.grid, U_m_s
        f_lo, f_hi = 1.0 / (setup.nperseg * setup.dt_s), 0.5 / setup.dt_s
        return {"f_min_hz": f_lo, "f_max_hz": f_hi, "k1_min_rad_m": 2 * np.pi * f_lo / U,
                "k1_max_rad_m": 2 * np.pi * f_hi / U, "welch_df_hz": f_lo, "record_df_hz": 1.0 / (grid.nt * grid.dt_s),
                "k2_nyquist_rad_m": np.pi / grid.dy_m, "k3_nyquist_rad_m": np.pi / grid.dz_m}


@dataclass
class Theory:
    """Model predictions on the store's grid (see module docstring). Lines are indexed j = 0 .. nt/2."""

    model: str
    nt: int
    line_f: np.ndarray
    auto: dict  # component -> (nl,) L_j
    yz: dict  # component -> {(a, b): (nl,) complex}
    long: dict  # |dx| rounded to 1e-6 m -> (nl,) u line covariance between planes (same y, z)
    rews: np.ndarray  # (nl,) rotor-effective wind speed lines
    node_f: np.ndarray  # (nn,) frequencies of the rho_bar nodes [Hz]
    rho_all: dict  # component -> (nn, nn) R(nu_i, nu_j) over all points and planes
    rho_yz: dict  # component -> {(a, b): (nn, nn)} over the first points of the pairs, all planes
    rho_long: np.ndarray  # (nn, nn) over the plane-pair sub-lattice, one plane
    rho_rews: np.ndarray  # (nn, nn) over the planes (REWS series)
    sigma_model: dict  # component -> sigma of the full model spectrum [m/s] (information)
    band: dict  # what the grid resolves (stated in the report)
    uw: np.ndarray | None = None  # (nl,) u-w line covariance (Mann F13; 0 for Kaimal)
    rho_uw: np.ndarray | None = None  # (nn,) cross-component term of the uw variance bound
    long_components: str = "u"
    auto_model: dict | None = None  # Mann: component -> (nl,) lines of the continuous model band-limited to the grid
    variance_modes: dict = field(default_factory=dict)  # component -> (J, K + 1) ``variance_law.top_modes``, lines 1..J
    # continuous-model curves for the plots, computed only for them: () -> {curve label: (f [Hz], S)}
    reference: Callable[[], dict] | None = None

    def long_lines(self, dx_m: float) -> np.ndarray:
        """(nl,) u line covariance [m^2 s^-2] between two planes ``dx_m`` [m] apart (same y, z)."""
        return self.long[dx_key(dx_m)]

    def rho(self, values: np.ndarray, f_hz) -> np.ndarray:
        """rho_bar node values (or the diagonal R(nu, nu) of a two-frequency sum) interpolated (linear in
        log f) to ``f_hz``, clipped to [0, 1]."""
        values = np.diagonal(values) if np.ndim(values) == 2 else values
        f = np.clip(np.asarray(f_hz, dtype=float), self.node_f[0], self.node_f[-1])
        return np.clip(np.interp(np.log(f), np.log(self.node_f), values), 0.0, 1.0)

    @property
    def pair_weights(self) -> np.ndarray:
        """Weight of line j in a variance: 2 (lines +-f_j), 1 for j = 0 and the single Nyquist line."""
        return pair_weights(self.nt)

    def variance(self, component: str) -> float:
        """Expected variance about each point's record mean: all lines but j = 0 [m^2 s^-2]."""
        return float(np.sum(self.pair_weights[1:] * self.auto[component][1:]))

    def band_variance(self, component: str) -> float:
        """Variance of the continuous model band-limited to the record's lines and the grid's Nyquist
        rectangle, without the box's point sampling (Mann; Kaimal: = variance) [m^2 s^-2]."""
        lines = self.auto[component] if self.auto_model is None else self.auto_model[component]
        return float(np.sum(self.pair_weights[1:] * lines[1:]))


def dx_key(dx_m: float) -> float:
    """Key of a plane separation: |dx| [m] rounded to 1e-6 m."""
    return round(abs(float(dx_m)), 6)


def plane_separations(grid: Grid) -> dict:
    """Distinct plane separations |x_p - x_q| [m] (``dx_key``) over ordered plane pairs -> number of such pairs."""
    return dict(Counter(dx_key(xp - xq) for xp in grid.x_m for xq in grid.x_m))

