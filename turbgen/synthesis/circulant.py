"""2-D circulant embedding of a distance-only coherence on a regular yz grid (exact Veers synthesis).

The wrapped kernel's 2-D FFT gives the torus eigenvalues; Z = FFT2(sqrt(lam / (My Mz)) xi)[:ny, :nz] has
E[Z Z^H] = C exactly when all are >= 0 (Dietrich & Newsam 1997). A kernel staying high over the grid is first
smoothly periodized (Bachmayr, Graham, Nguyen & Scheichl 2020). The torus grows while an eigenvalue is negative;
then small grids fall back to a dense square root, large ones clip and report the error."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from turbgen import fft

from turbgen.errors import ParameterError
from turbgen.synthesis.square_root import principal_sqrt

EIG_RTOL = 1e-10  # eigenvalues above -EIG_RTOL * max(lam) are rounding noise of an exactly non-negative spectrum
# the torus is enlarged (x1.5 per step; one decay length more with the smooth cut-off) at most this many times
MAX_ENLARGE = 4
# grids with at most this many points fall back to a dense (principal) square root; larger ones clip
CHOLESKY_MAX_POINTS = 2500
# kernel values below exp(-17) ~ 4e-8 count as zero when sizing the torus (the torus scales are float32: 6e-8)
CUTOFF_DECAYS = 17.0
# decay lengths of the smooth cut-off's torus beyond twice the grid (torus_plan; embed adds one per enlarging step)
SMOOTH_DECAYS = 5.0
# tori larger than this and than 4 x the grid's minimal torus (torus_cap) are not built: a dense factor instead
MAX_TORUS_POINTS = 1 << 21
# operations of one dense factor per N^3: eigh with eigenvectors and the product V sqrt(Lambda) V^T
# (benchmarks/README.md, "Measurements behind design choices")
DENSE_OPS_PER_N3 = 4.0
MAX_DENSE_FLOPS = 1.2e12  # at most this many floating-point operations for the dense factors of one component


def fft_size(n: int) -> int:
    """Smallest FFT-friendly (11-smooth, turbgen.fft.next_fast_len) integer >= n, at least 1."""
    return fft.next_fast_len(max(int(n), 1))


def torus_size(n: int, h_m: float, decay_length_m: float) -> int:
    """Torus period M (points) for n points spaced h and a kernel <= exp(-r / decay_length): M h >= max(2 (n - 1) h,
    12 decay_length), or only n - 1 + CUTOFF_DECAYS decay / h where the kernel has decayed below float32 rounding."""
    if n == 1:
        return 1
    if not math.isfinite(decay_length_m):
        return fft_size(2 * (n - 1))
    wrap = min(2 * (n - 1), n - 1 + math.ceil(CUTOFF_DECAYS * decay_length_m / h_m))
    return fft_size(max(wrap, math.ceil(12.0 * decay_length_m / h_m - 1e-9)))


@functools.lru_cache(maxsize=16)
def wrapped_distance(ny: int, nz: int, dy_m: float, dz_m: float, my: int, mz: int) -> np.ndarray:
    """Read-only distance [m] of every torus point (my x mz) from the origin, wrapped lags min(i, M - i) (cached)."""
    iy = np.arange(my)
    iz = np.arange(mz)
    ly = np.minimum(iy, my - iy) * dy_m
    lz = np.minimum(iz, mz - iz) * dz_m
    r = np.hypot(ly[:, None], lz[None, :])
    r.flags.writeable = False
    return r


def smooth_torus_size(n: int, h_m: float, decay_length_m: float, decays: float = SMOOTH_DECAYS) -> int:
    """Torus period M (points) with the smooth cut-off (:func:`torus_kernel`): M h >= 2 (n - 1) h + ``decays`` decay,
    FFT-friendly; more than 2 (n - 1) points, so the cut-off has room to fall."""
    return fft_size(2 * (n - 1) + max(1, math.ceil(decays * decay_length_m / h_m - 1e-9)))


def torus_plan(ny: int, nz: int, dy_m: float, dz_m: float, decay_length_m: float) -> tuple[int, int, bool]:
    """(My, Mz, smooth): the smaller of the classical torus (:func:`torus_size`) and, on 2-D grids with a finite decay
    length, the torus of the smooth cut-off (:func:`smooth_torus_size`); ``smooth`` says which (ties: classical)."""
    my, mz = torus_size(ny, dy_m, decay_length_m), torus_size(nz, dz_m, decay_length_m)
    if ny > 1 and nz > 1 and math.isfinite(decay_length_m):
        sy, sz = smooth_torus_size(ny, dy_m, decay_length_m), smooth_torus_size(nz, dz_m, decay_length_m)
        if sy * sz < my * mz:
            return sy, sz, True
    return my, mz, False


def smooth_cutoff(n: int, h_m: float, m: int) -> np.ndarray:
    """phi on the m wrapped lags min(i, m - i) h of one axis: 1 up to (n - 1) h (every lag of the grid), 0 from half the
    period m h / 2 on, and the C-infinity step psi(1 - t) / (psi(1 - t) + psi(t)), psi(t) = exp(-1/t), in between."""
    i = np.arange(m)
    lag = np.minimum(i, m - i) * h_m
    t = np.clip((lag - (n - 1) * h_m) / (0.5 * m * h_m - (n - 1) * h_m), 0.0, 1.0)
    with np.errstate(divide="ignore"):
        rise, fall = np.exp(-1.0 / t), np.exp(-1.0 / (1.0 - t))  # 0 at t = 0 and t = 1 respectively
    return fall / (fall + rise)


def torus_kernel(kernel, ny: int, nz: int, dy_m: float, dz_m: float, my: int, mz: int, smooth: bool) -> np.ndarray:
    """The kernel on the my x mz torus (wrapped lags), times the smooth cut-off phi(l_y) phi(l_z) if ``smooth``:
    equal to kernel(r) on every lag of the ny x nz grid either way."""
    c = kernel(wrapped_distance(ny, nz, dy_m, dz_m, my, mz))
    if smooth:
        c = c * smooth_cutoff(ny, dy_m, my)[:, None] * smooth_cutoff(nz, dz_m, mz)[None, :]
    return c


def grid_distances(ny: int, nz: int, dy_m: float, dz_m: float) -> np.ndarray:
    """Dense (N x N) matrix of distances between the N = ny nz grid points (y-major order)."""
    y, z = np.meshgrid(np.arange(ny) * dy_m, np.arange(nz) * dz_m, indexing="ij")
    p = np.column_stack([y.ravel(), z.ravel()])
    return np.sqrt(((p[:, None, :] - p[None, :, :]) ** 2).sum(-1))


@dataclass(frozen=True)
class Embedding:
    """Sampler of one correlation matrix C on the ny x nz grid: circulant (``scale`` = sqrt(lam/(My Mz))) or dense
    (``chol`` the principal square root of C); ``clip_error`` bounds the covariance error of clipping (0: exact)."""

    ny: int
    nz: int
    scale: np.ndarray | None
    chol: np.ndarray | None
    clip_error: float
    enlarged: int

    @property
    def torus_shape(self) -> tuple[int, int]:
        """(My, Mz) of the circulant torus, or (N, 1) for a dense factor."""
        return self.scale.shape if self.scale is not None else (self.ny * self.nz, 1)

    def sample(self, xi: np.ndarray, workers: int | None = None, overwrite: bool = False,
               transforms=None) -> np.ndarray:  # fmt: skip
        """Map standard complex normals xi (..., *torus_shape) to coefficients (..., ny, nz) with covariance C;
        ``overwrite``: xi may serve as the work array (destroyed)."""
        if self.chol is not None:
            z = np.einsum("ij,...j->...i", self.chol.astype(xi.real.dtype), xi[..., 0])
            return z.reshape(*xi.shape[:-2], self.ny, self.nz)
        scale = self.scale.astype(xi.real.dtype, copy=False)
        w = np.multiply(xi, scale, out=xi) if overwrite else xi * scale
        # only the ny x nz corner is needed: FFT along z, keep nz columns, then FFT along y (in place:
        # w is ours, a copy or the caller's work array)
        transforms = transforms or fft.oneshot()
        w = transforms.fft(w, axis=-1, workers=workers, overwrite_x=True)[..., : self.nz]
        return transforms.fft(w, axis=-2, workers=workers, overwrite_x=overwrite)[..., : self.ny, :]


def torus_cap(ny: int, nz: int) -> int:
    """Most torus points built for an ny x nz grid: MAX_TORUS_POINTS, or 4 x the grid's minimal torus
    (2 (n - 1) per axis) on grids that need more anyway."""
    return max(MAX_TORUS_POINTS, 4 * torus_size(ny, 1.0, math.inf) * torus_size(nz, 1.0, math.inf))


def dense_is_cheaper(n_points: int, torus_points: int) -> bool:
    """Whether a dense square root of a bin's n x n C (DENSE_OPS_PER_N3 n^3 + 4 n^2 operations) costs less than its
    torus of M = ``torus_points`` (~10 M log2(M) for the FFTs)."""
    m = max(int(torus_points), 2)
    return DENSE_OPS_PER_N3 * n_points**3 + 4.0 * n_points**2 <= 10.0 * m * math.log2(m)


def dense_sampled(ny: int, nz: int, torus_points: int, when_cheaper: bool = True) -> bool:
    """Whether a bin with a torus of ``torus_points`` is sampled densely instead: grids of at most
    CHOLESKY_MAX_POINTS points, a torus over :func:`torus_cap` or (``when_cheaper``) a cheaper dense factor."""
    n = ny * nz
    if n > CHOLESKY_MAX_POINTS:
        return False
    return torus_points > torus_cap(ny, nz) or (when_cheaper and dense_is_cheaper(n, torus_points))


def dense_embedding(kernel, ny: int, nz: int, dy_m: float, dz_m: float, enlarged: int = 0) -> Embedding:
    """Sampler of C_ab = kernel(r_ab) by its principal square root V sqrt(max(Lambda, 0)) V^T (unique: the same on
    every CPU), clip_error max|Lambda_neg|."""
    root, clipped = principal_sqrt(kernel(grid_distances(ny, nz, dy_m, dz_m)))
    return Embedding(ny, nz, None, root, clipped, enlarged)


def check_sampling_cost(ny: int, nz: int, dy_m: float, dz_m: float, decay_lengths_m, what: str) -> list[int]:
    """The torus points (My Mz) at every frequency of decay length ``decay_lengths_m`` [m]; ParameterError naming
    ``what`` for tori over :func:`torus_cap` on a grid too large for dense factors."""
    n = ny * nz
    cap = torus_cap(ny, nz)
    decays = list(decay_lengths_m)
    plans = [torus_plan(ny, nz, dy_m, dz_m, d) for d in decays]
    points = [my * mz for my, mz, _ in plans]
    big = [d for d, m in zip(decays, points) if m > cap]
    if big and (n > CHOLESKY_MAX_POINTS or len(big) * DENSE_OPS_PER_N3 * n**3 > MAX_DENSE_FLOPS):
        my, mz, _ = torus_plan(ny, nz, dy_m, dz_m, max(big))
        raise ParameterError(
            f"{what} stays high over {max(big):.4g} m: sampling it on the {ny} x {nz} grid would need a {my} x {mz} "
            f"torus (more than {cap} points) or a dense {n} x {n} factor at {len(big)} frequencies; "
            "raise `a_yz`, lower `lc_m` or use fewer grid points (`ny`, `nz`)"
        )
    return points


def embed_many(kernels, ny: int, nz: int, dy_m: float, dz_m: float, decay_lengths_m,
               dense_when_cheaper: bool = True) -> list[Embedding]:
    """:func:`embed` of every kernel, bit for bit, with one batched FFT per run of kernels on the same torus."""
    plans = [torus_plan(ny, nz, dy_m, dz_m, d) for d in decay_lengths_m]
    out: list[Embedding | None] = [None] * len(plans)
    i = 0
    while i < len(plans):
        j = i + 1
        while j < len(plans) and plans[j] == plans[i]:
            j += 1
        my, mz, smooth = plans[i]
        if dense_sampled(ny, nz, my * mz, dense_when_cheaper):
            for b in range(i, j):
                out[b] = embed(kernels[b], ny, nz, dy_m, dz_m, decay_lengths_m[b], dense_when_cheaper)
            i = j
            continue
        stack = np.empty((j - i, my, mz))
        for b in range(i, j):
            stack[b - i] = torus_kernel(kernels[b], ny, nz, dy_m, dz_m, my, mz, smooth)
        lam = fft.oneshot().fft2(stack, overwrite_x=True).real
        m = my * mz
        for b in range(i, j):
            one = lam[b - i]
            if (one < -EIG_RTOL * float(one.max())).any():  # enlarged, or a fallback
                out[b] = embed(kernels[b], ny, nz, dy_m, dz_m, decay_lengths_m[b], dense_when_cheaper)
            else:
                out[b] = Embedding(ny, nz, np.sqrt(np.maximum(one, 0.0) / m), None, 0.0, 0)
        i = j
    return out


def embed(kernel, ny: int, nz: int, dy_m: float, dz_m: float, decay_length_m: float,
          dense_when_cheaper: bool = True) -> Embedding:
    """Embedding of C_ab = kernel(r_ab) (kernel(0) = 1, r in m), kernel <= exp(-r / ``decay_length_m``)."""
    my, mz, smooth = torus_plan(ny, nz, dy_m, dz_m, decay_length_m)
    cap = torus_cap(ny, nz)
    if dense_sampled(ny, nz, my * mz, dense_when_cheaper):
        return dense_embedding(kernel, ny, nz, dy_m, dz_m)
    if my * mz > cap:
        raise ValueError(f"a {my} x {mz} torus for a {ny} x {nz} grid: check_sampling_cost should have refused it")
    enlarged = 0
    while True:
        lam = fft.oneshot().fft2(torus_kernel(kernel, ny, nz, dy_m, dz_m, my, mz, smooth)).real
        lam_max = float(lam.max())
        neg = lam < -EIG_RTOL * lam_max
        if not neg.any():
            break
        grown = (fft_size(math.ceil(1.5 * my)) if ny > 1 else 1, fft_size(math.ceil(1.5 * mz)) if nz > 1 else 1)
        if smooth:  # one decay length more per step (5 suffices on square grids, 6 on the anisotropic ones tried)
            more = SMOOTH_DECAYS + enlarged + 1
            grown = (max(smooth_torus_size(ny, dy_m, decay_length_m, more), fft_size(my + 1)),
                     max(smooth_torus_size(nz, dz_m, decay_length_m, more), fft_size(mz + 1)))
        if enlarged < MAX_ENLARGE and grown[0] * grown[1] > cap and ny * nz <= CHOLESKY_MAX_POINTS:
            return dense_embedding(kernel, ny, nz, dy_m, dz_m)  # a larger torus is not built
        if enlarged == MAX_ENLARGE or grown[0] * grown[1] > cap:
            if enlarged == MAX_ENLARGE and ny * nz <= CHOLESKY_MAX_POINTS:
                return dense_embedding(kernel, ny, nz, dy_m, dz_m, MAX_ENLARGE)
            break
        my, mz = grown
        enlarged += 1
    m = my * mz
    # the covariance at any lag changes by ifft2 of the clipped part: at most sum|lam_neg| / M
    clip_error = float(-lam[lam < 0].sum() / m)
    scale = np.sqrt(np.maximum(lam, 0.0) / m)
    return Embedding(ny, nz, scale, None, clip_error if neg.any() else 0.0, enlarged)
