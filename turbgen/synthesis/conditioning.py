"""Gaussian conditioning of a Mann field on measurement streams, exact for the generator's discrete prior.

Hoffman & Ribak (1991): with the prior u ~ N(0, C) (turbgen.synthesis.prior_spectrum), measurements
d = H u + eps, eps ~ N(0, R) and S = H C H^T + R, a conditional sample is

    u_c = u_s + C H^T S^-1 (d - H u_s - eps_s),      u_s ~ N(0, C), eps_s ~ N(0, R),

and C H^T S^-1 d is the conditional mean. Here H is a set of *streams*: stream a is a fixed linear combination of
field values of one plane p_a (terms: component, y index, z index, time shift s_t, weight):
y_a(n) = sum_t w_t u_(c_t)(n + s_t, y_t, z_t), observed every q stored time steps, z_a(m) = y_a(o_a + m q),
m = 0 .. nt/q - 1 (q = 1 for a point sensor; a lidar beam-gate measured once per scan; o_a its offset). The stored
time axis is the periodic xi axis of the synthesis box, so the covariance between two streams depends on the lag
only: S is block-circulant and the FFT over the nt/q samples makes it block-diagonal, one Hermitian
(streams x streams) matrix per frequency j. At full rate, slab i gives

    L_i[a, b] = nt sum_(t in a, t' in b) w_t w_t' G_i^(p_a p_b)[c_t, c_t'](y_t - y_t', z_t - z_t')
                * e^(2 pi i i (s_t - s_t') / nt)

with G_i^(pq)(dy, dz) = sum_(j, l) rho_pq Phi_i exp(2 pi i (j dy / nyp + l dz / nzp)) (one inverse 2-D FFT per slab
and plane pair; real part on the k1 = 0 / Nyquist slabs), and L_(nt - i) = conj L_i; the decimated streams alias the
q full-rate frequencies j + l nt/q onto j:
S_j[a, b] = (1/q) sum_l L_(j + l nt/q)[a, b] e^(2 pi i (j + l nt/q)(o_a - o_b) / nt) + sigma_a^2 delta_ab.
Missing samples (NaN) break the circulant structure:
S restricted to the observed samples is solved by conjugate gradients preconditioned with the circulant solve of the
full streams (S v itself is exact by the same FFTs). C H^T w is one spectral synthesis: the weights are scattered
into the (k2, k3) spectrum through the adjoint of the terms, multiplied by rho Phi and transformed back.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turbgen.errors import ParameterError
from turbgen.synthesis.mann_stencil import MannStencil
from turbgen.synthesis.prior_spectrum import slab_inv_tau, slab_spectrum, slab_weight

CG_TOLERANCE = 1e-10  # relative residual |S x - r| / |r| at which the conjugate gradients stop
CG_MAX_ITERATIONS = 1000
SINGULAR_RTOL = 1e-11  # eigenvalue / largest eigenvalue of S_i below which zero-noise measurements are dependent


@dataclass(frozen=True, eq=False)
class Streams:
    """Measurement streams on the stored grid (see module docstring).

    Parameters
    ----------
    plane : numpy.ndarray of int, (M,)
        Plane index of each stream (all its terms lie on it).
    term_stream, term_component, term_iy, term_iz : numpy.ndarray of int, (T,)
        For each term: its stream, component (0 u, 1 v, 2 w), y and z grid indices.
    term_weight : numpy.ndarray of float, (T,)
        The weight of each term [-] (interpolation weights times a projection on (u, v, w)).
    names : tuple of str
        A name per stream (for messages).
    term_shift : numpy.ndarray of int, (T,), optional
        Stored time steps s_t >= 0 by which each term is ahead of its stream's sample time (default 0).
    decimation : int, optional
        q: every stream is observed every q stored time steps (q divides nt; default 1).
    offset : numpy.ndarray of int, (M,), optional
        o_a in [0, q): the stored time step of each stream's first sample (default 0).
    """

    plane: np.ndarray
    term_stream: np.ndarray
    term_component: np.ndarray
    term_iy: np.ndarray
    term_iz: np.ndarray
    term_weight: np.ndarray
    names: tuple[str, ...]
    term_shift: np.ndarray | None = None
    decimation: int = 1
    offset: np.ndarray | None = None

    def __post_init__(self):
        if self.term_shift is None:
            object.__setattr__(self, "term_shift", np.zeros(len(self.term_stream), np.int64))
        if self.offset is None:
            object.__setattr__(self, "offset", np.zeros(len(self.plane), np.int64))

    @property
    def n_streams(self) -> int:
        """M, the number of streams."""
        return len(self.plane)

    def used_planes(self) -> np.ndarray:
        """The plane indices that carry streams, sorted."""
        return np.unique(self.plane)


def measure(streams: Streams, plane: int, component: int, field: np.ndarray, out: np.ndarray) -> None:
    """Add H's terms on (``plane``, ``component``) applied to ``field`` (nt, ny, nz) [m/s] into ``out`` (M, nt/q)."""
    sel = np.flatnonzero((streams.plane[streams.term_stream] == plane) & (streams.term_component == component))
    nt, q = field.shape[0], streams.decimation
    samples = np.arange(nt // q) * q
    for t in sel:
        a = streams.term_stream[t]
        n = (streams.offset[a] + samples + streams.term_shift[t]) % nt
        out[a] += streams.term_weight[t] * field[n, streams.term_iy[t], streams.term_iz[t]]


@dataclass(frozen=True, eq=False)
class _Footprints:
    """The streams' terms grouped by (stream, component, shift) key: ``basis[k](j, l) = sum_t w_t
    exp(2 pi i (j y_t / nyp + l z_t / nzp))`` over the terms of key k (K, nyp nzp), ``shift`` (K,) and ``row`` (K,)
    = 3 stream + component of each key."""

    basis: np.ndarray
    shift: np.ndarray
    row: np.ndarray


def _footprints(streams: Streams, box) -> _Footprints:
    keys = np.stack([streams.term_stream, streams.term_component, streams.term_shift], axis=1)
    uniq, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    ey = np.exp(2j * np.pi * np.outer(streams.term_iy, np.arange(box.nyp)) / box.nyp)
    ez = np.exp(2j * np.pi * np.outer(streams.term_iz, np.arange(box.nzp)) / box.nzp)
    basis = np.empty((len(uniq), box.nyp * box.nzp), complex)
    order = np.argsort(inverse, kind="stable")
    bounds = np.searchsorted(inverse[order], np.arange(len(uniq) + 1))
    for k in range(len(uniq)):
        sel = order[bounds[k] : bounds[k + 1]]
        basis[k] = ((ey[sel].T * streams.term_weight[sel]) @ ez[sel]).ravel()
    return _Footprints(basis, uniq[:, 2], 3 * uniq[:, 0] + uniq[:, 1])


def _transfer(fp: _Footprints, i: int, nt: int, m: int) -> np.ndarray:
    """A_i (M, 3, nyp nzp): the streams' transfer functions on slab i, sum over keys of e^(2 pi i i s / nt) basis."""
    from scipy import sparse

    phase = np.exp(2j * np.pi * i * fp.shift / nt)
    mix = sparse.csr_matrix((phase, (fp.row, np.arange(len(fp.row)))), shape=(3 * m, len(fp.row)))
    return np.asarray(mix @ fp.basis).reshape(m, 3, -1)


def _slab_phi(stencil: MannStencil, i: int) -> np.ndarray:
    """Phi_i (3, 3, nyp nzp), symmetrised under k -> -k on the k1 = 0 / Nyquist slabs (their real part: see
    prior_spectrum)."""
    phi = slab_spectrum(stencil, i)
    if slab_weight(stencil, i) == 1.0:
        phi = 0.5 * (phi + np.roll(phi[..., ::-1, ::-1], 1, axis=(-2, -1)))
    return phi.reshape(3, 3, -1)


def _phi_times(phi: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Phi v per (k2, k3) point: phi (3, 3, J), v (n, 3, J) -> (n, 3, J)."""
    out = np.zeros(v.shape, complex)
    for c in range(3):
        for d in range(3):
            out[:, c] += phi[c, d] * v[:, d]
    return out


def _rho(stencil: MannStencil, i: int, times_a: np.ndarray, times_b: np.ndarray) -> np.ndarray:
    """exp(-|t_a - t_b| / tau_e) (Pa, Pb, nyp nzp) of slab i (ones for frozen turbulence)."""
    box = stencil.box
    inv_tau = slab_inv_tau(stencil, i)
    if inv_tau is None:
        return np.ones((len(times_a), len(times_b), box.nyp * box.nzp))
    lag = np.abs(times_a[:, None] - times_b[None, :])
    return np.exp(-lag[:, :, None] * inv_tau.reshape(1, 1, -1))


def stream_covariance(stencil: MannStencil, streams: Streams, times_s, noise_var) -> np.ndarray:
    """The per-frequency matrices S_j (nt/q, M, M) complex128 [m^2 s^-2 times nt] of the block-circulant S.

    Parameters
    ----------
    stencil : MannStencil
        The run's stencil (with coefficients; with 1/tau_e for several evolving planes).
    streams : Streams
        The measurement streams.
    times_s : array_like
        The relative time x/U [s] of every plane of the run (storage order).
    noise_var : array_like, (M,)
        Measurement-noise variance sigma_a^2 [m^2 s^-2] of each stream (R = diag).

    Notes
    -----
    L_i[a, b] = nt sum_(c, c', k2, k3) A_i[a, c] (rho Phi)_(c c') conj(A_i[b, c']) with the transfer functions A_i
    of the streams (the same sum as over term pairs in the module docstring, arranged per (k2, k3)).
    """
    box = stencil.box
    nt, q, m = box.nt, streams.decimation, streams.n_streams
    n_dec = nt // q
    times = np.asarray(times_s, dtype=float)
    planes = streams.used_planes()
    members = [np.flatnonzero(streams.plane == p) for p in planes]
    slot = np.searchsorted(planes, streams.plane)
    fp = _footprints(streams, box)
    doff = 2j * np.pi * (streams.offset[:, None] - streams.offset[None, :]) / nt
    out = np.zeros((n_dec, m, m), complex)
    for i in range(box.nk1):
        a = _transfer(fp, i, nt, m)
        b = _phi_times(_slab_phi(stencil, i), a.conj())  # Phi conj(A) of every stream
        rho = _rho(stencil, i, times[planes], times[planes])[slot]  # (M, P, J): from each stream's plane
        full = np.empty((m, m), complex)
        for sq, rb in enumerate(members):  # the columns of the streams on plane q
            left = (a * rho[:, sq, None, :]).reshape(m, -1)
            full[:, rb] = left @ b[rb].reshape(len(rb), -1).T
        full *= nt
        out[i % n_dec] += full * np.exp(i * doff) / q
        if 0 < i and 2 * i != nt:  # the mirror frequency nt - i: L_(nt - i) = conj L_i
            out[(nt - i) % n_dec] += full.conj() * np.exp((nt - i) * doff) / q
    out[:, np.arange(m), np.arange(m)] += np.asarray(noise_var, dtype=float)
    return out


def check_singular(cov: np.ndarray, names) -> None:
    """Raise ParameterError naming the measurements that are linearly dependent (S_i singular on some slab)."""
    for i in range(cov.shape[0]):
        lam, vec = np.linalg.eigh(cov[i])
        top = max(lam[-1], np.finfo(float).tiny)
        if lam[0] <= SINGULAR_RTOL * top:
            v = np.abs(vec[:, 0])
            involved = [names[a] for a in np.flatnonzero(v > 0.1 * v.max())]
            raise ParameterError(
                "the measurements " + ", ".join(involved) + " are linearly dependent with zero noise (singular "
                f"system at frequency index {i}): remove one of them or give a noise level > 0 (`--noise`)"
            )


def circulant_apply(cov: np.ndarray, v: np.ndarray) -> np.ndarray:
    """S v for full streams ``v`` (M, nt/q): FFT over the samples, S_j per frequency, inverse FFT."""
    spec = np.fft.fft(v, axis=1)
    return np.fft.ifft(np.einsum("jab,bj->aj", cov, spec), axis=1).real


def circulant_solve(cov: np.ndarray, r: np.ndarray) -> np.ndarray:
    """S^-1 r for full streams ``r`` (M, nt/q): one dense solve per frequency."""
    spec = np.fft.fft(r, axis=1).T[:, :, None]
    return np.fft.ifft(np.linalg.solve(cov, spec)[:, :, 0].T, axis=1).real


@dataclass(frozen=True)
class SolveReport:
    """How S x = r was solved: ``method`` 'circulant' (every sample observed) or 'pcg'; ``iterations`` of the
    conjugate gradients (0 for the direct solve) and the final relative residual |S x - r| / |r| [-]."""

    method: str
    iterations: int
    relative_residual: float


def solve(cov: np.ndarray, r: np.ndarray, observed: np.ndarray,
          preconditioner: np.ndarray | None = None) -> tuple[np.ndarray, SolveReport]:  # fmt: skip
    """x = S^-1 r on the observed samples, zero elsewhere: (x (M, nt), report).

    Every sample observed: the exact per-slab solve. Otherwise preconditioned conjugate gradients on S restricted to
    the observed samples, the circulant solve of the full streams (zero-filled) as preconditioner, stopping at
    relative residual CG_TOLERANCE. Raises ParameterError if they do not converge in CG_MAX_ITERATIONS.
    ``preconditioner``: other per-frequency matrices for that circulant solve (default ``cov``; for a ``cov``
    singular on some frequency whose full streams are never all observed).
    """
    pre = cov if preconditioner is None else preconditioner
    r = np.where(observed, r, 0.0)
    norm = float(np.linalg.norm(r))
    if observed.all():
        x = circulant_solve(cov, r)
        res = np.linalg.norm(circulant_apply(cov, x) - r) / norm if norm > 0 else 0.0
        return x, SolveReport("circulant", 0, float(res))
    x = np.zeros_like(r)
    if norm == 0:
        return x, SolveReport("pcg", 0, 0.0)
    res = r.copy()
    z = np.where(observed, circulant_solve(pre, res), 0.0)
    p, rz = z.copy(), float(np.vdot(res, z))
    for it in range(1, CG_MAX_ITERATIONS + 1):
        sp = np.where(observed, circulant_apply(cov, p), 0.0)
        alpha = rz / float(np.vdot(p, sp))
        x += alpha * p
        res -= alpha * sp
        rel = float(np.linalg.norm(res)) / norm
        if rel <= CG_TOLERANCE:
            return x, SolveReport("pcg", it, rel)
        z = np.where(observed, circulant_solve(pre, res), 0.0)
        rz_new = float(np.vdot(res, z))
        p = z + (rz_new / rz) * p
        rz = rz_new
    raise ParameterError(
        f"the conditioning system did not converge in {CG_MAX_ITERATIONS} conjugate-gradient iterations (relative "
        f"residual {rel:.2e} > {CG_TOLERANCE:g}): the measurements are nearly dependent; give a noise level > 0"
    )


def correction_spectra(stencil: MannStencil, streams: Streams, weights: np.ndarray, times_s, planes_out, ny: int,
                       nz: int) -> np.ndarray:  # fmt: skip
    """The yz-transformed, cropped spectra of C H^T w on the planes ``planes_out``: (P_out, 3, nk1, ny, nz) complex64;
    :func:`spectra_field` turns one plane's into the field.

    Parameters
    ----------
    weights : numpy.ndarray, (M, nt/q)
        w, one value per stream sample (e.g. S^-1 (d - H u_s - eps_s)).
    times_s : array_like
        Relative time x/U [s] of every plane of the run.
    planes_out : sequence of int
        The plane indices wanted.

    Notes
    -----
    Per slab: H^T w in the (k2, k3) spectrum of each measured plane q, F_q = sum_(a on q) W_a(i) conj(A_i[a]) (W the
    FFT of the weights at full rate), then sum_q rho_pq Phi F_q, the inverse 2-D FFT and the crop; the real inverse
    FFT along time is left to spectra_field (it keeps only the real part of the k1 = 0 / Nyquist slabs).
    """
    box = stencil.box
    times = np.asarray(times_s, dtype=float)
    planes = streams.used_planes()
    planes_out = list(planes_out)
    members = [np.flatnonzero(streams.plane == p) for p in planes]
    q, m = streams.decimation, streams.n_streams
    full = np.zeros((m, box.nt))
    for a in range(m):  # the samples at their stored time steps o_a + m q
        full[a, streams.offset[a] :: q] = weights[a]
    spec_w = np.fft.rfft(full, axis=1)
    fp = _footprints(streams, box)
    out = np.zeros((len(planes_out), 3, box.nk1, ny, nz), np.complex64)
    for i in range(box.nk1):
        a = _transfer(fp, i, box.nt, m)
        # F_q = sum_(a on q) W_a(i) conj(A_i[a]), (P_in, 3, J)
        f = np.stack([(spec_w[ra, i].conj() @ a[ra].reshape(len(ra), -1)).reshape(3, -1) for ra in members]).conj()
        g = _phi_times(_slab_phi(stencil, i), f)  # (P_in, 3, J)
        rho = _rho(stencil, i, times[planes_out], times[planes])  # between each output and measured plane
        yz = np.zeros((len(planes_out), 3, g.shape[-1]), complex)
        for sq in range(len(planes)):
            yz += rho[:, sq, None, :] * g[sq][None]
        yz = yz.reshape(len(planes_out), 3, box.nyp, box.nzp)
        yz = np.fft.ifft2(yz, axes=(-2, -1)) * (box.nyp * box.nzp)
        out[:, :, i] = yz[:, :, :ny, :nz]
    return out


def spectra_field(spectra: np.ndarray, nt: int) -> np.ndarray:
    """The field (3, nt, ny, nz) float64 [m/s] of one plane's cropped spectra (3, nk1, ny, nz) (correction_spectra)."""
    return np.fft.irfft(spectra.astype(complex), n=nt, axis=1) * nt


def weights_field(stencil: MannStencil, streams: Streams, weights: np.ndarray, times_s, plane: int, ny: int,
                  nz: int) -> np.ndarray:  # fmt: skip
    """C H^T w on plane ``plane``, cropped to ny x nz: (3, nt, ny, nz) float64 (see correction_spectra)."""
    spectra = correction_spectra(stencil, streams, weights, times_s, [plane], ny, nz)
    return spectra_field(spectra[0], stencil.box.nt)
