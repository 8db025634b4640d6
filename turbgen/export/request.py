"""What the user asked for (one validated, frozen request) and what an export produced."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from turbgen.errors import ParameterError, check_int
from turbgen.export.shear import DEFAULT_SHEAR_EXPONENT, VerticalLayout, vertical_layout
from turbgen.theory import ranges

COMPONENTS = ("u", "v", "w")


@dataclass(frozen=True)
class ExportRequest:
    """Options shared by all formats.

    Parameters
    ----------
    plane : int, optional
        Index into the store's planes (None = the rotor plane, x = 0).
    hub_height_m : float, optional
        Overrides the store's hub height [m], in the range of ``turbgen.theory.ranges`` ([1, 1000]).
    shear_exponent : float, optional
        Power-law alpha [-]; None (default): ``DEFAULT_SHEAR_EXPONENT``. Given, it is refused by the
        formats without a mean profile, even at the default value.
    tower : bool, optional
        Add .bts tower points.
    periodic : bool, optional
        Flag the file periodic in time (InflowWind wraps); default True.
    drop_below_ground : bool, optional
        Drop grid rows at or below the ground instead of refusing.
    overwrite : bool, optional
        Replace existing outputs.
    source_label : str, optional
        How the exports name their source store (the .bts description, the HDF5 ``source_store``); default its
        path. The service gives ``/runs/<id>/store``, not its catalog's path on the server.

    Raises
    ------
    ParameterError
        For a non-integer ``plane`` or a ``hub_height_m`` outside its range.
    """

    plane: int | None = None
    hub_height_m: float | None = None
    shear_exponent: float | None = None
    tower: bool = False
    periodic: bool = True
    drop_below_ground: bool = False
    overwrite: bool = False
    source_label: str | None = None

    def source(self, fs) -> str:
        """The source store's name in the exports: ``source_label``, or the store's path."""
        return str(fs.path) if self.source_label is None else self.source_label

    def __post_init__(self):
        if self.plane is not None:
            # the range [0, nx - 1] depends on the store: checked in plane_index
            object.__setattr__(self, "plane", check_int("plane", self.plane, -(2**63), 2**63))
        if self.hub_height_m is not None:
            object.__setattr__(self, "hub_height_m", ranges.check("hub_height_m", self.hub_height_m))

    def plane_index(self, fs) -> int:
        """The plane to export from store ``fs`` (default: the plane at x = 0).

        Parameters
        ----------
        fs : FieldStore
            The open store.

        Returns
        -------
        int
            Plane index in [0, nx - 1].

        Raises
        ------
        ParameterError
            When ``plane`` is None and the store has no plane at x = 0 m, or ``plane`` is out of range.
        """
        xs = fs.grid.x_m
        if self.plane is None:
            if 0.0 not in xs:
                raise ParameterError(f"store has no rotor plane (x = 0 m) among x = {list(xs)}; choose one with `plane` 0..{len(xs) - 1}")
            return xs.index(0.0)
        if not 0 <= self.plane < len(xs):
            raise ParameterError(f"plane = {self.plane} is outside the allowed range [0, {len(xs) - 1}] (x = {list(xs)} m)")
        return self.plane

    def layout(self, fs) -> VerticalLayout:
        """Rows to export and the mean profile, for store ``fs``.

        Parameters
        ----------
        fs : FieldStore
            The open store; its hub height is used unless ``hub_height_m`` is set.

        Returns
        -------
        VerticalLayout
            See :func:`turbgen.export.shear.vertical_layout`.

        Raises
        ------
        ParameterError
            For a grid reaching the ground without ``drop_below_ground``, or a bad shear exponent.
        """
        hub = fs.hub_height_m if self.hub_height_m is None else self.hub_height_m
        alpha = DEFAULT_SHEAR_EXPONENT if self.shear_exponent is None else self.shear_exponent
        return vertical_layout(fs.grid, hub, alpha, drop_below_ground=self.drop_below_ground)


@dataclass(frozen=True)
class ExportResult:
    """Files written, the InflowWind input-file lines that load them, and remarks for the user."""

    paths: tuple[Path, ...]
    inflowwind_lines: tuple[str, ...]
    notes: tuple[str, ...] = field(default=())


class Plane:
    """One yz-plane as stored (float32 fluctuations, kept rows only) plus the power-law mean of u.

    Full velocities are made in float64 one time block at a time, so memory stays at about one
    stored plane.

    Parameters
    ----------
    fs : FieldStore
        The open store.
    ix : int
        Plane index.
    layout : VerticalLayout
        Kept rows and the mean profile.

    Raises
    ------
    ParameterError
        For a plane index out of range.
    StoreError
        When a chunk of the plane is corrupted or holds NaN/inf.
    """

    def __init__(self, fs, ix: int, layout: VerticalLayout):
        self.fluct = {c: fs.read_plane(c, ix)[:, :, layout.z_first:] for c in COMPONENTS}
        self.mean_u = layout.mean_u(fs.U_m_s)
        self.nt, self.ny, self.nz = self.fluct["u"].shape

    def full(self, c: str, a: int = 0, b: int | None = None) -> np.ndarray:
        """Full velocity [m/s] of component ``c`` for time steps a..b-1, float64 (b - a, ny, nz).

        Parameters
        ----------
        c : str
            "u", "v" or "w"; only u gets the power-law mean added.
        a : int, optional
            First time index (default 0).
        b : int, optional
            End time index, exclusive (default None: to the end).

        Returns
        -------
        numpy.ndarray
            float64 array (b - a, ny, nz) [m/s].
        """
        v = self.fluct[c][a:b].astype(np.float64)
        if c == "u":
            v += self.mean_u[None, None, :]
        return v

    def blocks(self, bytes_per_step: int, budget: int = 1 << 24):
        """(a, b) time blocks of at most ``budget`` bytes at ``bytes_per_step`` each.

        Parameters
        ----------
        bytes_per_step : int
            Bytes one time step takes [bytes].
        budget : int, optional
            Largest block [bytes]; default 16 MiB (at least one step per block).

        Returns
        -------
        list of tuple of (int, int)
            Consecutive half-open time ranges [a, b) covering 0..nt.
        """
        step = max(1, budget // max(1, bytes_per_step))
        return [(a, min(self.nt, a + step)) for a in range(0, self.nt, step)]


def ifw_line(value, key: str, comment: str) -> str:
    """One InflowWind input-file line: value, key name (second token), description.

    Parameters
    ----------
    value : object
        The value; strings and paths are quoted, floats written with 10 significant digits.
    key : str
        The InflowWind key name.
    comment : str
        Description after the key.

    Returns
    -------
    str
        The line, value right-aligned in 20 characters.
    """
    text = f'"{value}"' if isinstance(value, (str, Path)) else (str(value) if not isinstance(value, float) else f"{value:.10g}")
    return f"{text:>20}   {key:<15} - {comment}"
