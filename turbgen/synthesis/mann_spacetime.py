"""Mann space-time field: FFT synthesis (Mann 1998) of yz-plane snapshots evolving as Guo et al. (2022).

Plane x_n is a snapshot of the (xi = U t, y, z) box at time x_n / U; the Fourier noise follows the exact OU
recursion n_{m+1} = rho n_m + sqrt(1 - rho^2) xi, rho = exp(-dt / tau_e(k)), so every pair of planes has
<u_hat(k, t) u_hat^*(k, t + dt)> = exp(-|dt| / tau_e) Phi(k) dk (Guo et al. 2023, Eq. 13-14).
Memory scales with one snapshot."""

from __future__ import annotations

import queue
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from turbgen import fft
from turbgen.errors import ParameterError
from turbgen.resources import default_threads
from turbgen.synthesis.mann_product import ou_product
from turbgen.synthesis.mann_stencil import BoxShape, MannStencil
from turbgen.synthesis.pencil_crop import crop_into_pencils, gather_points
from turbgen.synthesis.random_streams import complex_normal


COMPONENTS = ("u", "v", "w")
SLAB_BATCH = 4  # k1 slabs per work unit (fixed: it fixes the FFT plan shapes, hence the rounding)
# slabs per task: SLAB_BATCH-slab units in turn, an on-demand stencil's coefficients computed for all at once
TASK_SLABS = 4 * SLAB_BATCH
ROW_BLOCK = 64  # (y, z) rows per real inverse FFT along k1
_ALIGN = 64
_PAGE = 4096
_SQRT_HALF = np.float32(np.sqrt(0.5))
# float64 temporaries per point of a stencil computed on demand (slab_factors: 4 float64 arrays of a task's points)
_COEF_TEMP_BYTES = 32


def _padded_nk1(nk1: int) -> int:
    return -(-nk1 // 8) * 8  # rows of 8 complex64 = 64 bytes keep every row aligned


def hermitian_complete(slab: np.ndarray) -> None:
    """Make the spectra of a k1 = 0 or Nyquist slab Hermitian in place, keeping E|.|^2:
    u_hat(k) <- (u_hat(k) + conj u_hat(-k)) / sqrt(2); without it the real inverse FFT keeps half their energy."""
    mirror = np.roll(slab[..., ::-1, ::-1], 1, axis=(-2, -1))  # u_hat(-k2, -k3), a copy
    np.conjugate(mirror, out=mirror)
    slab += mirror
    slab *= _SQRT_HALF


class _Scratch:
    """Per-thread buffers and FFT plans of ``backend`` (all plans built in the calling thread: FFTW's planner is not
    thread-safe)."""

    def __init__(self, box: BoxShape, nt: int, nz: int, n_slabs: int, backend: fft.FFTBackend,
                 coefficients: bool = False):  # fmt: skip
        b = SLAB_BATCH
        self._fft = backend
        self._shapes = shapes = self.shapes(box, nt, coefficients)
        self.coef = backend.empty(*shapes["coef"]) if coefficients else None
        self.noise, self.uhat, self.rows = (backend.empty(*shapes[k]) for k in ("noise", "uhat", "rows"))
        self.rho, self.sig = backend.empty(*shapes["rho_sig"])
        self.staged = None  # rows re-strided for the transposing copy (allocated with the plans along k1)
        # pruned 2-D inverse transform: along z on all nyp rows, then along y only on the nz kept columns
        self._yz: dict[int, tuple[fft.Plan, fft.Plan]] = {}
        for n in {min(b, n_slabs), n_slabs % b} - {0}:
            view, kept = self.uhat[:n], self.uhat[:n, :, :, :nz]
            self._yz[n] = (backend.plan("c2c_backward", view, view, 3), backend.plan("c2c_backward", kept, kept, 2))
        self._t: dict[int, fft.Plan] = {}

    @staticmethod
    def shapes(box: BoxShape, nt: int, coefficients: bool = False) -> dict:
        """{name: (shape, dtype)} of a thread's arrays: a task's on-demand stencil coefficients, noise and u_hat of a
        batch, the OU factors on the rows k2 >= 0, rows along k1 and their re-strided copy."""
        slab = (SLAB_BATCH, 3, box.nyp, box.nzp)
        shapes = {"noise": (slab, np.complex64), "uhat": (slab, np.complex64),
                  "rho_sig": ((2, SLAB_BATCH, box.nk2_half, box.nzp), np.float32),
                  "rows": ((ROW_BLOCK, nt), np.float32), "staged": ((ROW_BLOCK, nt + 16), np.float32)}
        if coefficients:
            shapes["coef"] = ((4, TASK_SLABS, box.nk2_half, box.nzp), np.float32)
        return shapes

    def arrays(self) -> list:
        """The arrays this thread holds."""
        return [a for a in (self.coef, self.noise, self.uhat, self.rho, self.sig, self.rows, self.staged)
                if a is not None]

    def yz_transform(self, n: int) -> None:
        """Inverse transform of uhat[:n] over (k2, k3), exact on the kept columns z < nz only."""
        along_z, along_y = self._yz[n]
        along_z.execute()
        along_y.execute()

    def plan_rows(self, spectra: np.ndarray) -> None:
        """Plans for blocks of ROW_BLOCK rows and for the last, shorter block of ``spectra`` (3, rows, nk1)."""
        rows = spectra.shape[1]
        self.staged = self._fft.empty(*self._shapes["staged"])
        for n in {min(ROW_BLOCK, rows), rows % ROW_BLOCK} - {0}:
            self._t[n] = self._fft.plan("c2r", spectra[0, :n], self.rows[:n], 1)

    def t_plan(self, n: int) -> fft.Plan:
        return self._t[n]


class MannSnapshots:
    """Generator of Mann space-time snapshots on one stencil, cropped to ny x nz; bit-identical for any ``threads``;
    ``fft_backend`` changes it at float32 round-off."""

    def __init__(self, stencil: MannStencil, ny: int, nz: int, threads: int | None = None, buffers: int = 1,
                 points: np.ndarray | None = None, fft_backend: str | None = None):  # fmt: skip
        box = stencil.box
        if not (1 <= ny <= box.nyp and 1 <= nz <= box.nzp):
            raise ParameterError(f"ny, nz = {ny}, {nz} must not exceed the synthesis box {box.nyp} x {box.nzp}")
        self.stencil, self.box, self.ny, self.nz = stencil, box, ny, nz
        self._first, self._end = stencil.slab_range  # a part of the box (out-of-core) or all of it
        if self._first % SLAB_BATCH:
            raise ValueError(f"a part of the stencil must start at a multiple of {SLAB_BATCH} slabs")
        self._n_slabs = self._end - self._first
        self.threads = default_threads(threads)
        self._fft = fft.backend(fft_backend)
        self._k1 = box.k1().astype(np.float32)
        self._k2 = box.k2().astype(np.float32)
        self._k3sq = (box.k3() ** 2).astype(np.float32)
        self._hermitian_slabs = {0, box.nt // 2} if box.nt % 2 == 0 else {0}
        self._spectra = None
        self._state = None
        self._n_buffers = 2 if buffers >= 2 else 1
        self._outputs: list[np.ndarray] = []
        self._n_out = 0
        self._scratch: queue.SimpleQueue | None = None
        self._scratches: list[_Scratch] = []
        # the cropped points y nz + z kept by :meth:`spectra` (None: all); such a generator yields no fields
        self._points = None if points is None else np.divmod(np.asarray(points, dtype=np.int64), nz)

    @classmethod
    def bytes_needed(cls, box: BoxShape, ny: int, nz: int, n_snapshots: int, threads: int, buffers: int = 1,
                     coefficients: bool = False) -> int:  # fmt: skip
        """Bytes [B] a whole-box generator allocates (:attr:`nbytes` once it has run; the stencil excluded): the
        shapes of _allocate and _Scratch; ``coefficients`` (a stencil computed on demand) adds the float64
        temporaries of computing them."""
        def size(shape, dtype) -> int:
            return int(np.prod(shape)) * np.dtype(dtype).itemsize

        spectra = size((3, ny * nz, _padded_nk1(box.nk1)), np.complex64)
        state = size((box.nk1, 3, box.nyp, box.nzp), np.complex64) if n_snapshots > 1 else 0
        outputs = (1 if n_snapshots == 1 else min(max(buffers, 1), 2)) * size((box.nt, ny, nz), np.float32)
        return spectra + state + outputs + threads * cls.thread_bytes(box, coefficients)

    @staticmethod
    def thread_bytes(box: BoxShape, coefficients: bool = False) -> int:
        """Bytes [B] of one thread's buffers (_Scratch.shapes; ``coefficients``: with their float64 temporaries)."""
        scratch = sum(int(np.prod(shape)) * np.dtype(dtype).itemsize
                      for shape, dtype in _Scratch.shapes(box, box.nt, coefficients).values())  # fmt: skip
        return scratch + (TASK_SLABS * box.nk2_half * box.nzp * _COEF_TEMP_BYTES if coefficients else 0)

    @property
    def nbytes(self) -> int:
        """Bytes [B] of the arrays allocated so far (spectra, OU state, output planes, per-thread scratch)."""
        arrays = [a for a in (self._spectra, self._state) if a is not None] + self._outputs
        arrays += [a for s in self._scratches for a in s.arrays()]
        return sum(a.nbytes for a in arrays)

    def generate(self, seed: int | None, times_s, addend=None, target=None) -> Iterator[tuple[int, str, np.ndarray]]:
        """Yield (plane index, component, field (nt, ny, nz) float32) for every plane and component; ``times_s``:
        relative times x/U [s]. The array is reused: consume it first. ``addend``: cropped spectra added before the
        transform along k1 (``seed=None``: the addend alone); ``target``: the array to transform into."""
        times = np.asarray(times_s, dtype=float)
        order = [int(i) for i in np.argsort(times, kind="stable")]
        frozen = self.stencil.params.evo_time_s is None
        if not frozen and self.stencil.inv_tau is None and len(order) > 1:
            raise ParameterError("this stencil was built with evolving=False: it serves one plane only")
        if seed is None and addend is None:
            raise ValueError("generate needs a seed, an addend or both")
        if self._points is not None:
            raise ValueError("a generator made with points yields their spectra only (spectra)")
        self._allocate(n_snapshots=1 if frozen or seed is None else len(order))  # no sample: no OU state
        with ThreadPoolExecutor(self.threads) as pool:
            if frozen:
                self._synthesise(pool, seed, 0, None)
                for c in range(3):
                    add = None if addend is None else addend(order[0], c)
                    dest = None if target is None else target(order[0], c)
                    out = self._transform(pool, c, single=True, add=add, sample=seed is not None, dest=dest)
                    for ix in order:
                        yield ix, COMPONENTS[c], out
                return
            previous = None
            for m, ix in enumerate(order):
                dt = None if previous is None else float(times[ix] - previous)
                self._synthesise(pool, seed, m, dt)
                previous = times[ix]
                for c in range(3):
                    add = None if addend is None else addend(ix, c)
                    dest = None if target is None else target(ix, c)
                    yield ix, COMPONENTS[c], self._transform(pool, c, single=len(order) == 1, add=add,
                                                             sample=seed is not None, dest=dest)  # fmt: skip

    def spectra(self, seed: int, times_s) -> Iterator[tuple[int, np.ndarray]]:
        """Yield (snapshot number, cropped spectra (3, ny nz or len(points), n_slabs) complex64) in time order (the
        first pass of an out-of-core run). The array is reused: consume it first."""
        times = np.sort(np.asarray(times_s, dtype=float), kind="stable")
        frozen = self.stencil.params.evo_time_s is None
        if not frozen and self.stencil.inv_tau is None and len(times) > 1:
            raise ParameterError("this stencil was built with evolving=False: it serves one plane only")
        times = times[:1] if frozen else times
        self._allocate(n_snapshots=len(times))
        alternate = [self._spectra] if self._points is None else [self._spectra, np.empty_like(self._spectra)]
        with ThreadPoolExecutor(self.threads) as pool:
            for m, t in enumerate(times):
                self._spectra = alternate[m % len(alternate)]  # where _batch gathers this snapshot
                self._synthesise(pool, seed, m, None if m == 0 else float(t - times[m - 1]))
                yield m, self._spectra[:, :, : self._n_slabs]

    def single_buffers(self, output: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Allocate what a single snapshot uses, (spectra, output plane or None), for a caller to touch ahead of
        :meth:`generate` (every value is written before it is read)."""
        self._allocate(n_snapshots=1)
        if output and not self._outputs:
            self._outputs.append(self._fft.empty((self.box.nt, self.ny, self.nz), np.float32, _PAGE))
        return self._spectra, self._outputs[0] if output else None

    def _allocate(self, n_snapshots: int) -> None:
        box = self.box
        if self._spectra is None:
            whole = self._n_slabs == box.nk1 and self._points is None
            n_points = self.ny * self.nz if self._points is None else len(self._points[0])
            # page-aligned (whole box): output planes in it (_transform) go to a direct-I/O writer without a bounce copy
            self._spectra = self._fft.empty((3, n_points, _padded_nk1(self._n_slabs)), np.complex64,
                                            _PAGE if whole else _ALIGN)  # fmt: skip
            self._scratch = queue.SimpleQueue()
            for _ in range(self.threads):
                scratch = _Scratch(box, box.nt, self.nz, self._n_slabs, self._fft, coefficients=self.stencil.coef is None)
                if whole:
                    scratch.plan_rows(self._spectra[:, :, : box.nk1])
                self._scratch.put(scratch)
                self._scratches.append(scratch)
        if n_snapshots > 1 and self._state is None:
            self._state = self._fft.empty((self._n_slabs, 3, box.nyp, box.nzp), np.complex64, _ALIGN)

    def _run(self, pool, fn, items) -> None:
        def task(item):
            s = self._scratch.get()
            try:
                fn(s, item)
            finally:
                self._scratch.put(s)

        for _ in pool.map(task, items):
            pass

    def _synthesise(self, pool, seed: int | None, m: int, dt: float | None) -> None:
        if seed is None:  # no sample: the addend alone (_rows)
            return
        self._run(pool, lambda s, i0: self._task(s, seed, m, dt, i0), range(self._first, self._end, TASK_SLABS))

    def _transform(self, pool, c: int, single: bool, add: np.ndarray | None = None, sample: bool = True,
                   dest: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
        """Component ``c`` of the current snapshot into the next output buffer (``single`` snapshot: components 1, 2
        into the spectra of 0, 1, transformed already); ``add`` (nk1, ny nz) added first (``sample=False``: instead);
        ``dest``: the output array instead of a buffer."""
        if dest is not None:
            out = dest
        elif single and c > 0:
            flat = self._spectra[c - 1].view(np.float32).reshape(-1)  # >= (nt + 2) ny nz floats
            out = flat[: self.box.nt * self.ny * self.nz].reshape(self.box.nt, self.ny, self.nz)
        else:
            k = self._n_out % self._n_buffers
            self._n_out += 1
            while len(self._outputs) <= k:  # page-aligned planes, allocated when first needed
                self._outputs.append(self._fft.empty((self.box.nt, self.ny, self.nz), np.float32, _PAGE))
            out = self._outputs[k]
        points = self.ny * self.nz
        rows = range(0, points, ROW_BLOCK)
        if add is not None and add.shape != (self.box.nk1, points):
            raise ValueError(f"the addend's shape {add.shape} is not (nk1, ny nz) = {(self.box.nk1, points)}")
        shape = (self.box.nt, self.ny, self.nz)
        flat = out.reshape(shape[0], -1) if out.shape == shape and out.dtype == np.float32 else None
        if flat is None or not np.may_share_memory(flat, out):  # a reshape that copied would drop the field
            raise ValueError(f"the target must be a float32 array of shape {shape} with contiguous (y, z) planes")
        self._run(pool, lambda s, r0: self._rows(s, c, r0, flat, add, sample), rows)
        return out

    def _task(self, s: _Scratch, seed: int, m: int, dt: float | None, i0: int) -> None:
        """Slabs [i0, i0 + TASK_SLABS): their coefficients, then batch by batch (the batches of SLAB_BATCH slabs)."""
        end = min(i0 + TASK_SLABS, self._end)
        coef, c0 = self.stencil.coefficients(i0, end, s.coef)
        for b0 in range(i0, end, SLAB_BATCH):
            self._batch(s, seed, m, dt, b0, coef, c0 + b0 - i0)

    def _batch(self, s: _Scratch, seed: int, m: int, dt: float | None, i0: int, coef: np.ndarray, c0: int) -> None:
        """One batch of slabs [i0, i0 + SLAB_BATCH): ``coef`` holds the stencil's coefficients with slab i0 at c0."""
        st = self.stencil
        i1 = min(i0 + SLAB_BATCH, self._end)
        b = i1 - i0
        j0, j1 = i0 - self._first, i1 - self._first  # local indices in the stencil part, state and spectra
        n = self._state[j0:j1] if self._state is not None else s.noise[:b]
        fresh = n if dt is None else s.noise[:b]
        for j in range(b):
            complex_normal(seed, m, i0 + j, fresh[j])
        if dt is not None:  # exact OU step over dt (Guo et al. 2023, Eq. 13-14), factors on the stored rows k2 >= 0
            rho, sig = s.rho[:b], s.sig[:b]
            np.multiply(st.inv_tau[j0:j1], np.float32(-dt), out=rho)
            np.exp(rho, out=rho)
            np.multiply(rho, rho, out=sig)
            np.subtract(np.float32(1.0), sig, out=sig)
            np.sqrt(sig, out=sig)
        ou_product(n.view(np.float32), fresh.view(np.float32), s.rho, s.sig, coef, c0, self._k1[i0:i1], self._k2,
                   self._k3sq, s.uhat[:b].view(np.float32), dt is not None)
        uh = s.uhat[:b]
        cells = st.cells_in(i0, i1)
        if cells.start < cells.stop:  # cell-averaged factors near the k1 axis (see mann_stencil)
            sl, row, col = (st.cell_index[cells, q] for q in range(3))
            sl = sl - i0
            uh[sl, :, row, col] = np.einsum("cij,cj->ci", st.cell_factor[cells], n[sl, :, row, col])
        for i in self._hermitian_slabs.intersection(range(i0, i1)):
            hermitian_complete(uh[i - i0])
        s.yz_transform(b)
        if self._points is None:
            crop_into_pencils(uh, self.ny, self.nz, self._spectra, j0)
        else:
            gather_points(uh, self._points[0], self._points[1], self._spectra, j0)

    def _rows(self, s: _Scratch, c: int, r0: int, output: np.ndarray, add: np.ndarray | None = None,
              sample: bool = True) -> None:  # fmt: skip
        """Rows [r0, r0 + ROW_BLOCK) of component ``c`` transformed along k1 into ``output`` (nt, ny nz)."""
        r1 = min(r0 + ROW_BLOCK, self.ny * self.nz)
        n = r1 - r0
        spectra = self._spectra[c, r0:r1, : self.box.nk1]
        if add is not None and sample:
            spectra += add[:, r0:r1].T
        elif add is not None:
            spectra[...] = add[:, r0:r1].T
        s.t_plan(n).execute(spectra, s.rows[:n])
        # Transposed through rows whose stride is not a power of two: read straight from s.rows (nt = 2^p) every
        # column hits the same cache sets
        staged = s.staged[:n, : self.box.nt]
        staged[...] = s.rows[:n]
        output[:, r0:r1] = staged.T


class PencilTransform:
    """The real inverse FFT along k1 of (y, z) points, block by block exactly as MannSnapshots does it (the same
    plans on buffers of the same layout), for the second pass of out-of-core runs; ``fft_backend`` as MannSnapshots'."""

    def __init__(self, nt: int, n_points: int, fft_backend: str | None = None):
        backend = fft.backend(fft_backend)
        self.nt, self.nk1 = nt, nt // 2 + 1
        self._buf = backend.empty((ROW_BLOCK, _padded_nk1(self.nk1)), np.complex64)
        self._rows = backend.empty((ROW_BLOCK, nt), np.float32)
        self._plans = {}
        for n in {min(ROW_BLOCK, n_points), n_points % ROW_BLOCK} - {0}:
            self._plans[n] = backend.plan("c2r", self._buf[:n, : self.nk1], self._rows[:n], 1)

    def __call__(self, spectra: np.ndarray, out: np.ndarray) -> None:
        """``spectra`` (n, nk1) complex64 of one block (n = ROW_BLOCK, or the last block's size) -> ``out`` (nt, n)."""
        n = spectra.shape[0]
        self._buf[:n, : self.nk1] = spectra
        self._plans[n].execute()
        out[...] = self._rows[:n].T


def mann_box(stencil: MannStencil, ny: int, nz: int, seed: int, threads: int | None = None) -> np.ndarray:
    """One frozen 3-D box (3, nt, ny, nz) float32 (snapshot 0 of ``seed``): the classic Mann (1998) field."""
    gen = MannSnapshots(stencil, ny, nz, threads)
    out = np.empty((3, stencil.box.nt, ny, nz), np.float32)
    for _, comp, field in gen.generate(seed, [0.0]):
        out[COMPONENTS.index(comp)] = field
    return out
