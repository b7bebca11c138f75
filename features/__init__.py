"""pdmkit.features: condition indicators, and their ranking and selection.

Signal functions take an array with the samples along ``axis`` (1-D for one member,
2-D ``(members, samples)`` for a batch) and are vectorised over members:

- :func:`stats` - time-domain statistics (group ``"stats"``);
- :func:`harmonic` - SINAD, SNR, THD as MATLAB computes them (group ``"harmonic"``);
- :func:`spectral` - Welch-PSD peaks, band powers and spectral shape (group ``"spectral"``);
- :func:`envelope_spectrum`, :func:`envelope_features`, :func:`bearing_frequencies` -
  bearing envelope analysis (group ``"envelope"``);
- :func:`cycle_features`, :func:`cycle_average` - per-stroke and phase-window indicators
  of cyclic machines, and the cycle-synchronous average (group ``"cycle"``).

:func:`extract` turns an array into a feature table (columns ``<group>/<Feature>``) and
:func:`extract_ensemble` an ensemble into one (``<signal>/<group>/<Feature>`` beside the
condition variables, indexed by member id). :func:`rank_features` ranks the columns
(Kruskal-Wallis, ANOVA, monotonicity, trendability, prognosability) and
:class:`SelectTopRanked` keeps the best ones inside a scikit-learn Pipeline.

Examples
--------
>>> import numpy as np
>>> import pdmkit.features as pf
>>> x = np.random.default_rng(0).normal(size=(3, 4096))
>>> table = pf.extract(x, fs=4096.0)
>>> table.shape
(3, 27)
>>> (table["stats/Kurtosis"] - 3).abs().lt(0.2).all()  # Gaussian noise: about 3
np.True_
"""

from pdmkit.features._ar import ar_feature_names, ar_features
from pdmkit.features._cycle import (
    CYCLE_LEVELS,
    EVENT_WINDOWS,
    cycle_average,
    cycle_feature_names,
    cycle_features,
)
from pdmkit.features._envelope import (
    CWRU_DRIVE_END,
    CWRU_FAN_END,
    BearingGeometry,
    EnvelopeSpectrum,
    bearing_frequencies,
    envelope_features,
    envelope_spectrum,
)
from pdmkit.features._extract import GROUPS, extract, extract_ensemble
from pdmkit.features._model_features import (
    FRACTIONAL_FEATURES,
    FRF_FEATURES,
    fractional_features,
    frf_features,
    hw_feature_names,
    hw_features,
)
from pdmkit.features._ranking import METHODS, FeatureRanking, SelectTopRanked, rank_features
from pdmkit.features._spectral import spectral
from pdmkit.features._stats import harmonic, stats

__all__ = [
    "CWRU_DRIVE_END",
    "CWRU_FAN_END",
    "CYCLE_LEVELS",
    "EVENT_WINDOWS",
    "FRACTIONAL_FEATURES",
    "FRF_FEATURES",
    "GROUPS",
    "METHODS",
    "BearingGeometry",
    "EnvelopeSpectrum",
    "FeatureRanking",
    "SelectTopRanked",
    "ar_feature_names",
    "ar_features",
    "bearing_frequencies",
    "cycle_average",
    "cycle_feature_names",
    "cycle_features",
    "envelope_features",
    "envelope_spectrum",
    "extract",
    "extract_ensemble",
    "fractional_features",
    "frf_features",
    "harmonic",
    "hw_feature_names",
    "hw_features",
    "rank_features",
    "spectral",
    "stats",
]
