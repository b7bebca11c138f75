"""Workflows people run, the CLI and reports.

:func:`classify` and :func:`compare_models` train and score fault classifiers;
:func:`compare_sensors` ranks sensors by accuracy and cost; :func:`run_rul` trains and
scores remaining-useful-life models (C-MAPSS, the twin's air-leak runs, your tables) and
:func:`predict_rul` answers a unit's RUL from a saved model and its history;
:func:`run_identify` identifies a linear model from a recording; :func:`run_mismatch`
explains where a model file and a recording differ. :func:`run_features`,
:func:`run_rank`, :func:`run_classify` and :func:`run_sensors` are the feature-table
commands, reading members or indicators from a :class:`TableSource`. Each ``run_*``
writes a JSON summary and a self-contained HTML :class:`Report`, as the ``pdmkit``
command of its name does.

The source thesis's study (its ``seed_*`` recipes and published numbers) is in
:mod:`pdmkit.experiments.thesis`.

Examples
--------
>>> import numpy as np, pandas as pd
>>> from pdmkit.experiments import classify
>>> rng = np.random.default_rng(0)
>>> y = np.repeat(["healthy", "worn"], 40)
>>> table = pd.DataFrame({"acc/stats/RMS": rng.normal(size=80) + (y == "worn") * 3.0,
...                       "acc/stats/Mean": rng.normal(size=80), "fault": y})
>>> classify(table, "fault", model="knn", top_k=1).summary()["features"]
['acc/stats/RMS']
"""

from importlib import import_module as _import_module

__all__ = [
    "IDENTIFY_STRUCTURES",
    "LEAK_DEFAULTS",
    "MODELS",
    "SELECTIONS",
    "ClassificationResult",
    "FaultClassifier",
    "HealthHistory",
    "Report",
    "RunDirectory",
    "SensorComparison",
    "SensorCosts",
    "TableSource",
    "classify",
    "compare_models",
    "compare_sensors",
    "extract_features_run",
    "fingerprint_ensemble",
    "fingerprint_path",
    "leak_accuracy",
    "leak_indicators",
    "load_sensor_costs",
    "make_classifier",
    "make_rul_model",
    "package_versions",
    "predict_members",
    "predict_rul",
    "run_classify",
    "run_features",
    "run_identify",
    "run_mismatch",
    "run_monitor_fit",
    "run_monitor_score",
    "run_predict",
    "run_rank",
    "run_rul",
    "run_sensors",
    "simulate_leak_dataset",
    "split_run_to_failure",
    "watch_folder",
]

#: public name -> the module that defines it; imported on first use, so that the
#: command line (``pdmkit.experiments._cli``) starts without loading every workflow
_LAZY = {
    "TableSource": "_sources",
    "run_classify": "_classify_run",
    "run_predict": "_classify_run",
    "FaultClassifier": "_deploy",
    "run_features": "_table_workflows",
    "run_rank": "_table_workflows",
    "run_sensors": "_table_workflows",
    "ClassificationResult": "_classify_result",
    "MODELS": "_classify",
    "SELECTIONS": "_classify",
    "classify": "_classify",
    "compare_models": "_classify",
    "make_classifier": "_classify",
    "IDENTIFY_STRUCTURES": "_identify",
    "run_identify": "_identify",
    "run_mismatch": "_mismatch",
    "run_monitor_fit": "_monitor",
    "run_monitor_score": "_monitor",
    "watch_folder": "_monitor",
    "HealthHistory": "_monitor_history",
    "Report": "_report",
    "LEAK_DEFAULTS": "_rul",
    "leak_accuracy": "_rul",
    "leak_indicators": "_rul",
    "make_rul_model": "_rul",
    "predict_rul": "_rul",
    "run_rul": "_rul",
    "simulate_leak_dataset": "_rul",
    "split_run_to_failure": "_rul",
    "RunDirectory": "_runs",
    "extract_features_run": "_runs",
    "fingerprint_ensemble": "_runs",
    "fingerprint_path": "_runs",
    "package_versions": "_runs",
    "predict_members": "_runs",
    "SensorComparison": "_sensors",
    "SensorCosts": "_sensor_costs",
    "compare_sensors": "_sensors",
    "load_sensor_costs": "_sensor_costs",
}


def __getattr__(name: str):
    """Import the workflow module that defines ``name`` on first access.

    Examples
    --------
    >>> import pdmkit.experiments as experiments
    >>> experiments.run_rul.__module__
    'pdmkit.experiments._rul'
    """
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'pdmkit.experiments' has no attribute {name!r}")
    return getattr(_import_module(f"pdmkit.experiments.{module}"), name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
