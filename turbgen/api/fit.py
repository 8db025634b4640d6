"""``turbgen.fit_mann``: the Mann model fitted to measured or generated data (``turbgen fit mann DATA``)."""

from __future__ import annotations

import os

from turbgen.validation.fit import MannFit, fit_mann_data, load_fit_data
from turbgen.validation.fit.evolution import with_evolution


def fit_mann(data, *, U: float | None = None, nperseg: int | None = None) -> MannFit:
    """Fit ae, L, Gamma (Mann 1994) to the spectra of ``data`` and the evolution time gamma to its x coherence.

    The one-point spectra of u, v, w and the u-w co-spectrum are estimated (Welch, detrended), each band weighted by
    the estimator's own covariance; a turbgen store is fitted against the Mann tensor summed over its generator's box
    (what the grid can hold), sensor data against the continuous model (Mann 1994, Eq. 13-17; Guo et al. 2023,
    Eq. 8).

    Parameters
    ----------
    data : str, os.PathLike, turbgen.spec.constraints.PointSeries, FieldStore or xarray.Dataset
        A point-series JSON file (the ``--constrain`` format: one or more sensors with any of u, v, w), a field
        store, or a field as a Dataset (``turbgen.mann``, in memory or not, ``turbgen.open_store``).
    U : float, optional
        Mean wind speed [m/s] of k1 = 2 pi f / U for fluctuation data (default: the mean of u of total-wind data;
        a store holds its own).
    nperseg : int, optional
        Welch segment length [samples] (default: the largest power of two <= nt / 8, at most 4096).

    Returns
    -------
    turbgen.validation.fit.MannFit
        ``ae``, ``length_scale_m``, ``gamma`` (each ``value`` and ``ci95``), ``chi2_dof``, ``flags`` (no
        convergence, a range boundary: ``ok`` is False), ``notes``, ``to_dict()``, ``table()``, ``plot(path)``;
        ``evolution``: the eddy-evolution time from the co-coherence of u at points along x (two masts, two
        planes), None without such points (Guo et al. 2023, Eq. 13, 16).

    Raises
    ------
    ParameterError
        For bad input: an unreadable file, a non-uniform or non-stationary record, too few Welch segments.
    StoreError
        For a directory that is not a complete turbgen store.

    Examples
    --------
    >>> import turbgen
    >>> fit = turbgen.fit_mann("examples/mast-fit.json")  # doctest: +SKIP
    >>> fit.length_scale_m.value, fit.length_scale_m.ci95  # doctest: +SKIP
    """
    if isinstance(data, os.PathLike):
        data = os.fspath(data)
    fit_data = load_fit_data(data, U)
    return with_evolution(fit_data, fit_mann_data(fit_data, nperseg))
