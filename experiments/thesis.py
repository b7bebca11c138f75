"""The source thesis's study on the twin (docs/seed_study.md): its recipes and numbers.

The seed, a master's thesis on a double-acting pneumatic piston rig, reports its
numbers from MATLAB's Diagnostic Feature Designer and Classification Learner; each
``seed_*`` recipe here follows its text and its author's code on the digital twin and
returns a :class:`SeedResult` with the seed's published number beside pdmkit's.
:func:`run_seed_study` runs them all and writes the report; ``pdmkit demo`` runs a
smaller set. pdmkit's general workflows are in :mod:`pdmkit.experiments`.

Examples
--------
>>> from pdmkit.experiments.thesis import SEED_NUMBERS
>>> SEED_NUMBERS["flow_knn"]
('7.3.4, table 7.2', 'accuracy %', 97.52)
"""

from pdmkit.experiments._seed_indicators import (
    RIG_TABLE_SENSOR_ACCURACY,
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

__all__ = [
    "RIG_TABLE_SENSOR_ACCURACY",
    "SEED_NUMBERS",
    "SEED_SENSOR_ACCURACY",
    "SEED_SENSOR_RECIPES",
    "SeedResult",
    "SeedSensorRecipe",
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
]
