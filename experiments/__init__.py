"""Workflows people run: classify faults, compare sensors, the demo; the CLI and reports.

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
from pdmkit.experiments._mismatch import run_mismatch
from pdmkit.experiments._report import Report
from pdmkit.experiments._sensors import (
    SensorComparison,
    SensorCosts,
    compare_sensors,
    load_sensor_costs,
)

__all__ = [
    "MODELS",
    "SELECTIONS",
    "ClassificationResult",
    "Report",
    "SensorComparison",
    "SensorCosts",
    "classify",
    "compare_models",
    "compare_sensors",
    "load_sensor_costs",
    "make_classifier",
    "run_mismatch",
]
