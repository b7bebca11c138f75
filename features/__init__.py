"""pdmkit.features: condition indicators, and their ranking and selection.

Signal functions take an array with the samples along ``axis`` (1-D for one member,
2-D ``(members, samples)`` for a batch) and are vectorised over members:

- :func:`stats` - time-domain statistics (group ``"stats"``);
- :func:`harmonic` - SINAD, SNR, THD as MATLAB computes them (group ``"harmonic"``);
- :func:`spectral` - Welch-PSD peaks, band powers and spectral shape (group ``"spectral"``);
  :func:`matlab_pwelch` - the Welch PSD with MATLAB's defaults (the Feature Designer's);
- :func:`envelope_spectrum`, :func:`envelope_features`, :func:`bearing_frequencies` -
  bearing envelope analysis (group ``"envelope"``);
- :func:`cycle_features`, :func:`cycle_average` - per-stroke and phase-window indicators
  of cyclic machines, and the cycle-synchronous average (group ``"cycle"``).

:func:`extract` turns an array into a feature table (columns ``<group>/<Feature>``) and
:func:`extract_ensemble` an ensemble into one (``<signal>/<group>/<Feature>`` beside the
condition variables, indexed by member id). Each group is one :class:`FeatureGroup` in
the registry :data:`FEATURE_GROUPS` (its options with their defaults, its indicator
names, its computation); :func:`plan_extraction` and :func:`extract_task` open the
ensemble extraction to other drivers (resumable runs, clusters).
:func:`rank_features` ranks the columns (Kruskal-Wallis, ANOVA, Fisher ratio, ROC AUC,
Bhattacharyya distance; monotonicity, trendability, prognosability),
:func:`ranking_stability` repeats a class ranking on cross-validation folds, and
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

from importlib import import_module as _import_module

__all__ = [
    "CLASS_METHODS",
    "CWRU_DRIVE_END",
    "CWRU_FAN_END",
    "CYCLE_LEVELS",
    "ERROR_COLUMNS",
    "EVENT_WINDOWS",
    "FEATURE_GROUPS",
    "FRACTIONAL_FEATURES",
    "FRF_FEATURES",
    "GROUPS",
    "METHODS",
    "BearingGeometry",
    "EnvelopeSpectrum",
    "ExtractionPlan",
    "FeatureGroup",
    "FeatureRanking",
    "RankingStability",
    "SelectTopRanked",
    "ar_feature_names",
    "ar_features",
    "bearing_frequencies",
    "check_group_options",
    "check_groups",
    "cycle_average",
    "cycle_feature_names",
    "cycle_features",
    "envelope_features",
    "envelope_spectrum",
    "extract",
    "extract_ensemble",
    "extract_task",
    "fractional_features",
    "frf_features",
    "group_of_option",
    "harmonic",
    "hw_feature_names",
    "hw_features",
    "matlab_pwelch",
    "plan_extraction",
    "rank_features",
    "ranking_stability",
    "spectral",
    "stats",
]

#: public name -> the module that defines it, imported on first use: ``import
#: pdmkit.features`` stays light (no scikit-learn, no pdmkit.models) until a ranking
#: or a model-based group is asked for
_LAZY = {
    "ar_feature_names": "_ar",
    "ar_features": "_ar",
    "CYCLE_LEVELS": "_cycle",
    "EVENT_WINDOWS": "_cycle",
    "cycle_average": "_cycle",
    "cycle_feature_names": "_cycle",
    "cycle_features": "_cycle",
    "BearingGeometry": "_envelope",
    "CWRU_DRIVE_END": "_envelope",
    "CWRU_FAN_END": "_envelope",
    "EnvelopeSpectrum": "_envelope",
    "bearing_frequencies": "_envelope",
    "envelope_features": "_envelope",
    "envelope_spectrum": "_envelope",
    "ERROR_COLUMNS": "_plan",
    "ExtractionPlan": "_plan",
    "extract_ensemble": "_plan",
    "extract_task": "_plan",
    "plan_extraction": "_plan",
    "extract": "_extract",
    "FEATURE_GROUPS": "_groups",
    "FeatureGroup": "_groups",
    "GROUPS": "_groups",
    "check_group_options": "_groups",
    "check_groups": "_groups",
    "group_of_option": "_groups",
    "FRACTIONAL_FEATURES": "_model_features",
    "FRF_FEATURES": "_model_features",
    "fractional_features": "_model_features",
    "frf_features": "_model_features",
    "hw_feature_names": "_model_features",
    "hw_features": "_model_features",
    "CLASS_METHODS": "_ranking",
    "FeatureRanking": "_ranking",
    "METHODS": "_ranking",
    "RankingStability": "_ranking_stability",
    "ranking_stability": "_ranking_stability",
    "SelectTopRanked": "_selection",
    "rank_features": "_ranking",
    "spectral": "_spectral",
    "matlab_pwelch": "_spectral",
    "harmonic": "_stats",
    "stats": "_stats",
}


def __getattr__(name: str):
    """Import the module that defines ``name`` on first access.

    Examples
    --------
    >>> import pdmkit.features as pf
    >>> pf.rank_features.__module__
    'pdmkit.features._ranking'
    """
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'pdmkit.features' has no attribute {name!r}")
    return getattr(_import_module(f"pdmkit.features.{module}"), name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
