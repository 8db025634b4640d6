"""``turbgen.validate``, ``turbgen.export``, ``turbgen.lidar`` and ``turbgen.info``: what is made from a field (a store
path, a FieldStore, a Dataset of :func:`turbgen.open_store` or a field in memory), as the commands make it."""

from __future__ import annotations

import os
from pathlib import Path

from turbgen.errors import ParameterError
from turbgen.store import FieldStore, open_store as _open_field_store
from turbgen.store.paths import check_output_path


DECODE_LIMIT_BYTES = 256 * 2**20  # info decodes every chunk of a store up to this size on disk


def field_store(store) -> FieldStore:
    """The open FieldStore of a path, a FieldStore, an opened store's Dataset or a field in memory (MemoryField)."""
    if isinstance(store, FieldStore):
        return store
    if store is None:
        raise ParameterError("store = None; give a store path, a FieldStore or a Dataset of turbgen.open_store")
    if isinstance(store, (str, os.PathLike)):
        return _open_field_store(store)
    source = getattr(store, "encoding", {}).get("source")
    if source is None:
        from turbgen.store.memory_field import memory_field

        return memory_field(store)
    return _open_field_store(source)


def validate(store, *, plots: str | os.PathLike | None = None, overwrite: bool = False,
             rotor_radius: float | None = None):
    """Re-estimate a store's statistics and compare them with its model on its grid (``turbgen validate``).

    Parameters
    ----------
    store : str, os.PathLike, FieldStore or xarray.Dataset
        The store, or a field (``turbgen.mann(...)``, in memory or with ``out``).
    plots : str or os.PathLike, optional
        Write one PNG per comparison (estimate, 95 % band, theory) into this directory.
    overwrite : bool, optional
        Replace PNGs already in ``plots``.
    rotor_radius : float, optional
        Rotor radius R [m] of the rotor-effective wind speed (default 63 m, or the largest disc in the grid).

    Returns
    -------
    turbgen.validation.ValidationReport
        ``passed``, ``failed``, ``metrics``, ``table()``, ``to_dict()`` (``turbgen validate --json``), ``plots(dir)``.

    Raises
    ------
    StoreError
        If the store is missing, incomplete or corrupted.
    ParameterError
        For bad input.

    Examples
    --------
    >>> import turbgen
    >>> ds = turbgen.kaimal(nt=256, ny=6, nz=6, planes=[0, 50])
    >>> report = turbgen.validate(ds)
    >>> report.passed, "spectrum_u" in [m.name for m in report.metrics]
    (True, True)
    """
    from turbgen.validation import validate as run_validation

    fs = field_store(store)
    if plots is not None:
        check_plots_dir(plots, overwrite)
    report = run_validation(fs, rotor_radius_m=rotor_radius)
    if plots is not None:
        report.plots(plots)
    return report


def check_plots_dir(plots_dir: str | os.PathLike, overwrite: bool, name: str = "`plots`") -> None:
    """Refuse, before any work, a plots path that is a file, unwritable, or holds PNGs without ``overwrite``."""
    p = Path(plots_dir)
    if p.exists():
        if not p.is_dir():
            raise ParameterError(f"{name} = {str(plots_dir)!r} is a file, not a directory")
        if not os.access(p, os.W_OK):
            raise ParameterError(f"{name} = {str(plots_dir)!r} is not writable")
        if not overwrite and any(p.glob("*.png")):
            flag = "--overwrite" if name.startswith("--") else "overwrite=True"
            raise ParameterError(f"{name} = {str(plots_dir)!r} already holds PNG files; pass {flag} to replace them")
        return
    check_output_path(plots_dir, name, create_parents=True)  # report.plots makes missing directories


def export(store, format: str, out: str | os.PathLike, *, plane: int | None = None,
           hub_height: float | None = None, shear_exponent: float | None = None, profile: str | None = None,
           veer: float | None = None, mean_history: str | os.PathLike | None = None, transient: str | None = None,
           iec_class: str | None = None, rotor_diameter: float | None = None, transient_start: float = 10.0,
           transient_sign: str = "+", tower: bool = False, periodic: bool = True, drop_below_ground: bool = False,
           runner_files: bool = True, overwrite: bool = False):
    """Write a store for InflowWind, HAWC2, the lidar simulator, the 4D Mann scripts or HDF5 (``turbgen export``).

    The keywords are ``turbgen export``'s options (turbgen.exporters.options.export_request); the mean wind is a
    :class:`turbgen.spec.mean_wind.MeanWind`.

    Parameters
    ----------
    store : str, os.PathLike, FieldStore or xarray.Dataset
    format : str
        ``bts``, ``wnd``, ``evo``, ``hawc2``, ``mt4d`` or ``hdf5``.
    out : str or os.PathLike
        Output file, or ROOT for wnd, evo and hawc2.
    plane : int, optional
        Plane index (default: the rotor plane, x = 0).
    hub_height : float, optional
        Hub height [m] (default: the store's).
    shear_exponent : float, optional
        Power-law exponent of the mean profile added to u (InflowWind formats; default 0.2).
    profile : str, optional
        ``power:ALPHA``, ``log:z0=Z0[,d=D]`` or ``table:FILE`` (CSV z [m], U [m/s] [, direction deg]).
    veer : float, optional
        Direction change with height [deg/m], counter-clockwise seen from above.
    mean_history : str or os.PathLike, optional
        CSV of t [s], U [m/s] [, direction deg] at hub height.
    transient, iec_class : str, optional
        Superimposed IEC transient (EOG, EDC, ECD, EWS-V, EWS-H) and class, e.g. "IIB".
    rotor_diameter : float, optional
        Rotor diameter D [m] (with ``transient``).
    transient_start : float, optional
        Time the transient reaches the turbine [s].
    transient_sign : str, optional
        "+" or "-": the standard's sense of the transient.
    tower : bool, optional
        bts: add tower points down to the ground.
    periodic : bool, optional
        Flag bts/wnd/evo periodic in time.
    drop_below_ground : bool, optional
        Drop grid rows at or below the ground instead of refusing.
    runner_files : bool, optional
        Also write the InflowWind input file, the HAWC2 block (hawc2) and the LidarSim section (evo).
    overwrite : bool, optional
        Replace existing output files.

    Returns
    -------
    turbgen.exporters.ExportResult
        ``paths`` written, ``inflowwind_lines`` that load them, ``notes``.

    Raises
    ------
    ParameterError
        For an unknown format or unused options, an existing output, a grid reaching the ground, too little disk or
        values outside their ranges.
    StoreError
        If the store is missing or incomplete.

    Examples
    --------
    >>> import tempfile, turbgen
    >>> tmp = tempfile.mkdtemp()
    >>> ds = turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 50], out=tmp + "/k.zarr")
    >>> result = turbgen.export(ds, "bts", tmp + "/k.bts", profile="log:z0=0.03", veer=-0.1)
    >>> result.inflowwind_lines[0].split()[:2]
    ['3', 'WindType']
    """
    from turbgen.exporters import export_store
    from turbgen.exporters.options import ExportOptions, export_request

    check_output_path(out, "`out`")
    fs = field_store(store)
    opts = ExportOptions(plane=plane, hub_height_m=hub_height, shear_exponent=shear_exponent, profile=profile,
                         veer_deg_per_m=veer, mean_history=None if mean_history is None else str(mean_history),
                         transient=transient, iec_class=iec_class, rotor_diameter_m=rotor_diameter,
                         transient_start_s=transient_start, transient_sign=transient_sign, tower=tower,
                         periodic=periodic, drop_below_ground=drop_below_ground, runner_files=runner_files,
                         overwrite=overwrite)
    return export_store(fs, format, out, export_request(fs, format, opts))


def lidar(store, lidar: str | os.PathLike | None = None, *, out: str | os.PathLike | None = None,
          overwrite: bool = False, rotor_radius: float | None = None, mean_wind: bool = False, shear: float = 0.2,
          profile: str | None = None, veer: float | None = None, mean_history: str | os.PathLike | None = None,
          plots: str | os.PathLike | None = None):
    """Measure a store with a virtual lidar and compare its preview quality with theory (``turbgen lidar``).

    Parameters
    ----------
    store : str, os.PathLike, FieldStore or xarray.Dataset
        The store; its planes must include the lidar's range gates.
    lidar : str or os.PathLike, optional
        A lidar preset (``nacelle-4beam``, ``spinner-cw``, ``spinner-pulsed``, ``nacelle-1beam``) or a TOML/JSON
        lidar file; default: the 4-beam pulsed lidar of Guo et al. (2023), Table 3.
    out : str or os.PathLike, optional
        Write the lidar dataset (zarr: v_los, u_LL, u_RR, the lidar parameters) here; ``overwrite``: replace it.
    overwrite : bool, optional
    rotor_radius : float, optional
        Rotor radius R [m] of u_RR (default: the lidar's turbine if it fits the grid, else as :func:`validate`).
    mean_wind : bool, optional
        Add the mean wind to u before projecting: the power law of ``shear`` [-], or ``profile``, ``veer`` and
        ``mean_history`` as :func:`export` takes them.
    shear : float, optional
    profile, veer, mean_history : optional
    plots : str or os.PathLike, optional
        Write the plots of gamma^2_RL and ``|G_RL|`` (simulated with 95 % band, theory) into this directory.

    Returns
    -------
    turbgen.virtual_lidar.report.LidarReport
        ``passed``, ``to_dict()`` (the keys of ``turbgen lidar --json``), ``text()``, ``plots(directory)``.

    Raises
    ------
    ParameterError
        For an unknown lidar, gates that are not planes of the store, a beam leaving the grid, an existing ``out``.
    StoreError
        If the store is missing or incomplete.

    Examples
    --------
    >>> import tempfile, turbgen
    >>> ds = turbgen.mann(nt=256, ny=16, nz=16, dy=8, gates="50:170:13.3", pad_yz=1,
    ...                   out=tempfile.mkdtemp() + "/m.zarr")
    >>> report = turbgen.lidar(ds)
    >>> report.passed, sorted(report.to_dict())[:2]
    (True, ['G_RL_simulated', 'G_RL_theory'])
    """
    result = lidar_report(store, lidar, out, overwrite, rotor_radius, mean_wind, shear, profile, veer, mean_history)
    if out is not None:
        result.write(out, overwrite=overwrite)
    if plots is not None:
        result.plots(plots)
    return result


def lidar_report(store, lidar, out, overwrite: bool, rotor_radius, add: bool, shear_exponent: float, profile, veer,
                 history):
    """The LidarReport of :func:`lidar` and ``turbgen lidar`` (``out`` checked, not written): the mean wind of
    ``profile``, ``veer``, ``history`` (each needs ``add``; a profile defaults to the power law of ``shear_exponent``)
    added to u when ``add``."""
    from turbgen.spec.mean_wind_files import mean_wind_from_options
    from turbgen.virtual_lidar import report
    from turbgen.virtual_lidar.dataset import check_output

    given = [n for n, v in (("--profile", profile), ("--veer", veer), ("--mean-history", history)) if v is not None]
    if given and not add:
        raise ParameterError(f"{', '.join(given)} belong to --mean-wind")
    if profile is None and given:
        profile = f"power:{shear_exponent!r}"
    wind = mean_wind_from_options(profile, veer, None if history is None else str(history))
    fs = field_store(store)
    if out is not None:
        check_output(out, overwrite)
    return report.lidar_report(fs, None if lidar is None else str(lidar), rotor_radius_m=rotor_radius,
                               add_mean_wind=add, shear_exponent=shear_exponent, mean_wind=wind)  # fmt: skip


def info(store) -> dict:
    """What ``turbgen info`` shows of a store, a field or an exported file, as JSON-serialisable values.

    Parameters
    ----------
    store : str, os.PathLike, FieldStore or xarray.Dataset
        A store, a field (in memory or opened), or an exported .bts, InflowWind .dat or .sum file.

    Returns
    -------
    dict
        A field: model, grid, shape_t_x_y_z, duration_s [s], U_m_s [m/s], seed, parameters, units,
        size_on_disk_bytes, ... and chunks_decoded (every value read and checked: up to DECODE_LIMIT_BYTES on
        disk, and in memory). A file: its header rows.

    Raises
    ------
    StoreError
        If the store is missing, incomplete or corrupted (a value that does not decode or is not finite).

    Examples
    --------
    >>> import turbgen
    >>> s = turbgen.info(turbgen.kaimal(nt=64, ny=4, nz=4, planes=[0, 50]))
    >>> s["model"], s["shape_t_x_y_z"], s["path"], s["chunks_decoded"]
    ('kaimal', [64, 2, 4, 4], None, True)
    """
    if isinstance(store, (str, os.PathLike)) and Path(store).expanduser().is_file():
        from turbgen.exporters.describe import file_summary

        return dict(file_summary(Path(store).expanduser().absolute()))
    fs = field_store(store)
    summary = fs.summary() | ({"fit": fs.attrs["fit"]} if "fit" in fs.attrs else {})  # a replay's fit record
    summary["chunks_decoded"] = summary["size_on_disk_bytes"] <= DECODE_LIMIT_BYTES
    if summary["chunks_decoded"]:
        fs.check_chunks()
    return summary
