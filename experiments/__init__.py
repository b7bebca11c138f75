"""Workflows people run, the CLI and reports.

:func:`classify` and :func:`compare_models` train and score fault classifiers;
:func:`compare_sensors` ranks sensors by accuracy and cost; :func:`run_rul` trains and
scores remaining-useful-life models (C-MAPSS, the twin's air-leak runs, your tables) and
:func:`predict_rul` answers a unit's RUL from a saved model and its history;
:func:`run_identify` identifies a linear model from a recording; :func:`run_mismatch`
explains where a model file and a recording differ. Each ``run_*`` writes a JSON
summary and a self-contained HTML :class:`Report`, as the ``pdmkit`` command does.

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

from pdmkit.experiments._classify import (
    MODELS,
    SELECTIONS,
    ClassificationResult,
    classify,
    compare_models,
    make_classifier,
)
from pdmkit.experiments._identify import IDENTIFY_STRUCTURES, run_identify
from pdmkit.experiments._mismatch import run_mismatch
from pdmkit.experiments._report import Report
from pdmkit.experiments._rul import (
    LEAK_DEFAULTS,
    leak_accuracy,
    leak_indicators,
    make_rul_model,
    predict_rul,
    run_rul,
    simulate_leak_dataset,
    split_run_to_failure,
)
from pdmkit.experiments._runs import (
    RunDirectory,
    extract_features_run,
    fingerprint_ensemble,
    fingerprint_path,
    package_versions,
    predict_members,
)
from pdmkit.experiments._seed_indicators import (
    SEED_NUMBERS,
    SEED_SENSOR_ACCURACY,
    SEED_SENSOR_RECIPES,
    SeedResult,
    SeedSensorRecipe,
    seed_feature_table,
    seed_indicators,
    seed_rank,
)
from pdmkit.experiments._seed_recipes import (
    seed_air_leak_rul,
    seed_flow_bagged_trees,
    seed_flow_knn,
    seed_flow_pca_bagged_trees,
    seed_residual_classification,
    seed_sensor_faults,
    seed_sensor_table,
)
from pdmkit.experiments._seed_study import run_seed_study, seed_comparison
from pdmkit.experiments._sensors import (
    SensorComparison,
    SensorCosts,
    compare_sensors,
    load_sensor_costs,
)

__all__ = [
    "IDENTIFY_STRUCTURES",
    "LEAK_DEFAULTS",
    "MODELS",
    "SEED_NUMBERS",
    "SEED_SENSOR_ACCURACY",
    "SEED_SENSOR_RECIPES",
    "SELECTIONS",
    "ClassificationResult",
    "Report",
    "RunDirectory",
    "SeedResult",
    "SeedSensorRecipe",
    "SensorComparison",
    "SensorCosts",
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
    "run_identify",
    "run_mismatch",
    "run_rul",
    "run_seed_study",
    "seed_air_leak_rul",
    "seed_comparison",
    "seed_feature_table",
    "seed_flow_bagged_trees",
    "seed_flow_knn",
    "seed_flow_pca_bagged_trees",
    "seed_indicators",
    "seed_rank",
    "seed_residual_classification",
    "seed_sensor_faults",
    "seed_sensor_table",
    "simulate_leak_dataset",
    "split_run_to_failure",
]
