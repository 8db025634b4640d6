"""Fitting the Mann (or Kaimal) model to measured or generated data: ``turbgen fit mann DATA``, ``turbgen.fit_mann``.

Modules: ``data`` (point-series files and stores as detrended fluctuation series), ``spectra`` (Welch band estimates
and their variances), ``table`` (the one-point spectra tabulated in k1 L and Gamma), ``model`` (expected band
estimates and cross-spectra between points: continuous, or on a store's lattice), ``covariance`` (the joint
covariance of the band estimates), ``mann`` (the generalised least-squares fit), ``result`` (MannFit); ``kaimal``,
``kaimal_coherence``, ``kaimal_result``: the IEC Kaimal spectra and u coherence fitted the same way (KaimalFit)."""

from turbgen.validation.fit.data import FitData, load_fit_data
from turbgen.validation.fit.mann import fit_mann_data
from turbgen.validation.fit.result import FitValue, MannFit

__all__ = ["FitData", "FitValue", "MannFit", "fit_mann_data", "load_fit_data"]
