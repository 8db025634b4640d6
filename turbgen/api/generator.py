"""Reusable generators: what does not depend on the seed is made once, then one field per seed, the fields of
``turbgen.mann`` / ``turbgen.kaimal`` and the commands bit for bit (turbgen.runs)."""

from __future__ import annotations

import os
import threading
from collections.abc import Iterable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Generic, TypeVar

from turbgen.grid import Grid
from turbgen.resources import default_threads
from turbgen.spec.kaimal import KaimalRun
from turbgen.spec.mann import MannRun
from turbgen.theory.params import KaimalParams, MannParams

if TYPE_CHECKING:  # annotations only: a command that writes a store never imports xarray (pandas with it)
    import xarray as xr

PathLike = str | os.PathLike


RunT = TypeVar("RunT", MannRun, KaimalRun)


class _Generator(Generic[RunT]):
    """What both generators share: a run whose seed is replaced per field."""

    run: RunT

    @property
    def grid(self) -> Grid:
        """The field grid."""
        return self.run.grid

    def _in_memory(self, run: RunT, progress: bool) -> xr.Dataset:
        raise NotImplementedError

    def _to_store(self, run: RunT, path: Path, overwrite: bool, chunks: int | None, progress: bool) -> None:
        raise NotImplementedError

    def field(self, seed: int = 1, *, out: PathLike | None = None, overwrite: bool = False,
              chunks: int | None = None, progress: bool = False) -> xr.Dataset:  # fmt: skip
        """The field of ``seed``: u, v, w (t, x, y, z) [m/s] as ``turbgen.mann(...)`` / ``turbgen.kaimal(...)`` returns it.

        Parameters
        ----------
        seed : int, optional
            Random seed (>= 0). Default 1.
        out : str or os.PathLike, optional
            Write the field to a new store there and return it opened lazily; default: in memory.
        overwrite : bool, optional
            Replace an existing store at ``out``.
        chunks : int, optional
            Time samples per store chunk (with ``out``); never changes the field.
        progress : bool, optional
            Show a progress bar on stderr.

        Returns
        -------
        xarray.Dataset

        Raises
        ------
        ParameterError
            For a seed outside [0, 2^63 - 1] or a field that does not fit the available memory.
        StoreError
            For an existing ``out`` without ``overwrite``.
        """
        from turbgen.api.fields import open_store
        from turbgen.store.paths import check_output_path
        from turbgen.store.writer import check_new_store

        run = replace(self.run, seed=seed)
        if out is None:
            return self._in_memory(run, progress)
        check_output_path(out, "`out`")
        check_new_store(out, run.grid, chunk_t=chunks, overwrite=overwrite)
        self._to_store(run, Path(out), overwrite, chunks, progress)
        return open_store(out)

    def fields(self, seeds: Iterable[int]) -> Iterator[xr.Dataset]:
        """Yield the field of each of ``seeds`` in memory, in order (:meth:`field`)."""
        for seed in seeds:
            yield self.field(seed)


class MannGenerator(_Generator[MannRun]):
    """Mann space-time fields (Mann 1994; Guo et al. 2022) of one parameter set and grid, one per seed.

    The constructor builds the stencil in memory (:attr:`nbytes`); each field then costs its random coefficients and
    transforms only.

    Parameters
    ----------
    params : MannParams
        ae [m^(4/3) s^-2], length_scale_m [m], gamma [-], lifetime, factor1, factor2, evo_time_s [s] (None: frozen).
    grid : Grid
        nt samples dt_s [s] apart, planes x_m [m upstream], ny x nz points dy_m x dz_m [m].
    U_m_s : float, optional
        Mean wind speed [m/s] (dx = U dt). Default 16.
    hub_height_m : float, optional
        Hub height [m] recorded with the field. Default 150.
    pad_yz : int, optional
        The synthesis box is pad_yz times wider in y and z than the grid (cropped). Default 2.
    threads : int, optional
        Worker threads (default: all cores); never changes the field.

    Raises
    ------
    ParameterError
        For a value outside its range, or a stencil that does not fit the available memory.
    TypeError
        For ``params`` that are not MannParams or a ``grid`` that is not a Grid.

    Examples
    --------
    >>> import turbgen
    >>> g = turbgen.MannGenerator(turbgen.MannParams(ae=0.1, length_scale_m=30, gamma=3.1),
    ...                           turbgen.Grid(nt=64, dt_s=0.5, x_m=(0, 40), ny=8, nz=8, dy_m=8, dz_m=8), pad_yz=1)
    >>> a, b = g.fields([1, 2])
    >>> dict(a.sizes), b.attrs["seed"]
    ({'t': 64, 'x': 2, 'y': 8, 'z': 8}, 2)
    >>> bool((g.field(seed=1).u == a.u).all())
    True
    """

    def __init__(self, params: MannParams, grid: Grid, U_m_s: float = 16.0, *,
                 hub_height_m: float = 150.0, pad_yz: int = 2,
                 threads: int | None = None):  # fmt: skip
        from turbgen.runs.mann import build_mann_stencil
        from turbgen.synthesis.mann_spacetime import MannSnapshots

        self.run = MannRun(params, grid, U_m_s, 1, hub_height_m, pad_yz)
        self.threads = default_threads(threads)
        self._stencil = build_mann_stencil(self.run)
        # its buffers and FFT plans are made by the first field and kept for the next seeds
        self._snapshots = MannSnapshots(self._stencil, grid.ny, grid.nz, self.threads, buffers=2)
        self._lock = threading.Lock()  # one field at a time: the snapshots' buffers serve each in turn

    def __repr__(self) -> str:
        r = self.run
        return f"MannGenerator({r.params!r}, {r.grid!r}, U_m_s={r.U_m_s!r}, hub_height_m={r.hub_height_m!r}, " \
               f"pad_yz={r.pad_yz!r})"

    @property
    def params(self) -> MannParams:
        """The Mann parameters."""
        return self.run.params

    @property
    def nbytes(self) -> int:
        """Bytes [B] held between fields: the stencil and the snapshot buffers (MannSnapshots.bytes_needed)."""
        from turbgen.synthesis.mann_spacetime import MannSnapshots
        from turbgen.synthesis.mann_stencil import synthesis_box

        s, g = self._stencil, self.run.grid
        snapshots = 1 if s.inv_tau is None else g.nx
        held = sum(a.nbytes for a in (s.coef, s.inv_tau) if a is not None)
        return held + MannSnapshots.bytes_needed(synthesis_box(self.run), g.ny, g.nz, snapshots, self.threads, 2)

    def _in_memory(self, run: MannRun, progress: bool) -> xr.Dataset:
        from turbgen.runs.mann import mann_in_memory

        with self._lock:
            return mann_in_memory(run, progress=progress, stencil=self._stencil, threads=self.threads,
                                  snapshots=self._snapshots)[0]  # fmt: skip

    def _to_store(self, run: MannRun, path: Path, overwrite: bool, chunks: int | None, progress: bool) -> None:
        from turbgen.runs.mann import run_mann

        run_mann(run, path, overwrite=overwrite, chunk_t=chunks, progress=progress, stencil=self._stencil,
                 threads=self.threads)

class KaimalGenerator(_Generator[KaimalRun]):
    """Kaimal 4D fields (IEC 61400-1; longitudinal coherence of Guo et al. 2023, Eq. 18) of one parameter set and
    grid, one per seed: the yz samplers and longitudinal factors made by the first field are kept, so a further seed
    costs its random draws and transforms only.

    Parameters
    ----------
    params : KaimalParams
        sigma_m_s [m/s], length_scales_m [m], a_yz [-], lc_m [m] (:func:`turbgen.theory.iec_kaimal_params`: IEC values).
    grid : Grid
        As :class:`MannGenerator`'s.
    U_m_s : float, optional
        Hub-height mean wind speed [m/s]. Default 16.
    hub_height_m : float, optional
        Hub height [m] recorded with the field. Default 90.
    long_model : {"exp", "simley-pao", "kristensen"}, optional
        Longitudinal coherence model. Default "exp".
    a_x, b_x : float, optional
        a_x [-] and b_x [1/m] of the "exp" model (default: Guo et al. 2023, Table 2, neutral).
    long_components : {"u", "uvw"}, optional
        Components given the longitudinal coherence. Default "u".
    vw_coherence : {"white", "exp"}, optional
        v, w incoherent in yz (IEC) or with the u coherence. Default "white".
    rescale : bool, optional
        Scale the spectra so the expected sigma is the nominal one.
    coherence : Mapping or callable, optional
        User yz coherence, as ``turbgen.kaimal``'s.
    threads : int, optional
        FFT threads (default: all cores); never changes the field.

    Raises
    ------
    ParameterError
        For a value outside its range.
    TypeError
        For ``params`` that are not KaimalParams or a ``grid`` that is not a Grid.

    Examples
    --------
    >>> import turbgen
    >>> iec = turbgen.theory.iec_kaimal_params(12.0, "A", 90.0)  # U [m/s], class, hub height [m]
    >>> g = turbgen.KaimalGenerator(iec, turbgen.Grid(nt=64, dt_s=0.5, x_m=(0, 50), ny=4, nz=4, dy_m=5, dz_m=5),
    ...                             U_m_s=12)
    >>> [ds.attrs["seed"] for ds in g.fields([3, 4])]
    [3, 4]
    """

    def __init__(self, params: KaimalParams, grid: Grid, U_m_s: float = 16.0, *,
                 hub_height_m: float = 90.0, long_model: str = "exp",
                 a_x: float | None = None, b_x: float | None = None,
                 long_components: str = "u",
                 vw_coherence: str = "white", rescale: bool = False, coherence=None,
                 threads: int | None = None):  # fmt: skip
        self.run = KaimalRun(params, grid, U_m_s, 1, hub_height_m, long_model, a_x, b_x,
                             long_components, rescale, vw_coherence, coherence=coherence)  # fmt: skip
        self.threads = threads
        from turbgen.runs.kaimal import kaimal_generator

        self._evo = kaimal_generator(self.run, workers=threads, keep=True)
        self._lock = threading.Lock()  # one field at a time: the kept samplers are made by the first

    def __repr__(self) -> str:
        return f"KaimalGenerator({self.run.kaimal!r}, {self.run.grid!r}, U_m_s={self.run.U_m_s!r})"

    @property
    def params(self) -> KaimalParams:
        """The Kaimal parameters."""
        return self.run.kaimal

    def _in_memory(self, run: KaimalRun, progress: bool) -> xr.Dataset:
        from turbgen.runs.kaimal import kaimal_in_memory

        with self._lock:
            return kaimal_in_memory(run, progress=progress, threads=self.threads, gen=self._evo.reseeded(run.seed))[0]

    def _to_store(self, run: KaimalRun, path: Path, overwrite: bool, chunks: int | None, progress: bool) -> None:
        from turbgen.runs.kaimal import run_kaimal

        with self._lock:
            run_kaimal(run, path, overwrite=overwrite, chunk_t=chunks, progress=progress, threads=self.threads,
                       gen=self._evo.reseeded(run.seed))
