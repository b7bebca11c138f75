"""pdmkit.rul: remaining-useful-life models and prognostic metrics.

Every model is an estimator on a long run-to-failure table (``unit``, ``time`` or
``cycle``, indicator columns, optional ``failed``): ``fit(table)`` returns the model,
``predict(table)`` returns a :class:`RULPrediction` (estimate, interval, ``to_pandas``,
``plot``) for each unit at its last time, and ``predict_trajectory(table)`` the RUL at
every point of each unit's history.

- Health indicators: :class:`RegimeNormalizer`, :func:`smooth_indicators`,
  :func:`prognostic_ranking`, :class:`HealthIndicator`.
- Degradation models (Bayesian updating, threshold crossing):
  :class:`LinearDegradationModel`, :class:`ExponentialDegradationModel`; a Wiener
  process (random-walk degradation, first-passage RUL): :class:`WienerDegradationModel`,
  the same read through measurement noise (Kalman filter):
  :class:`NoisyWienerDegradationModel`, and the monotone counterpart
  :class:`GammaProcessDegradationModel`.
- Similarity models: :class:`ResidualSimilarityModel`, :class:`PairwiseSimilarityModel`,
  :class:`HashSimilarityModel`.
- Survival models: :class:`ReliabilitySurvivalModel` (Weibull and friends, censoring),
  :class:`CovariateSurvivalModel` (proportional hazards with time-varying covariates).
- Learned models: :class:`BoostingRULModel` (gradient-boosted trees on windowed
  indicators, cross-conformal intervals), :class:`NeuralRULModel` (small torch LSTM /
  1-D CNN over windows).
- :class:`ConformalRUL`: any model's intervals rescaled, on held-out training units,
  to hold their level.
- :class:`RULPipeline`: a health indicator and a model in one object (what
  ``pdmkit rul`` saves and ``pdmkit rul --trained`` loads).
- Input checks: :func:`ood_scores` (test units outside the training rows),
  :func:`shutdown_endings` (units whose last rows look switched off).
- Metrics: :func:`rmse`, :func:`mae`, :func:`phm08_score`, :func:`interval_coverage`,
  :func:`alpha_lambda_accuracy`, :func:`relative_accuracy`, :func:`prognostic_horizon`,
  :func:`rul_metrics`.

Examples
--------
>>> import numpy as np, pandas as pd
>>> from pdmkit.rul import ResidualSimilarityModel
>>> rows = [pd.DataFrame({"unit": u, "time": np.arange(life), "hi": np.arange(life) / life})
...         for u, life in enumerate([50, 70, 90])]
>>> train = pd.concat(rows, ignore_index=True)
>>> model = ResidualSimilarityModel(k=1, degree=1).fit(train)
>>> test = pd.DataFrame({"unit": "new", "time": np.arange(30), "hi": np.arange(30) / 70})
>>> model.predict(test).to_pandas()[["unit", "time", "rul"]]
  unit  time   rul
0  new  29.0  40.0
"""

from pdmkit.rul._base import resolve_keys, timestamps_to_seconds
from pdmkit.rul._boosting import BoostingRULModel
from pdmkit.rul._conformal import ConformalRUL
from pdmkit.rul._degradation import ExponentialDegradationModel, LinearDegradationModel
from pdmkit.rul._diagnostics import OOD_THRESHOLD, ood_scores, shutdown_endings
from pdmkit.rul._gamma import GammaProcessDegradationModel
from pdmkit.rul._indicators import (
    HealthIndicator,
    RegimeNormalizer,
    prognostic_ranking,
    smooth_indicators,
)
from pdmkit.rul._metrics import (
    alpha_lambda_accuracy,
    coverage_check,
    interval_coverage,
    mae,
    phm08_score,
    prognostic_horizon,
    relative_accuracy,
    rmse,
    rul_metrics,
)
from pdmkit.rul._neural import NeuralRULModel
from pdmkit.rul._pipeline import RULPipeline
from pdmkit.rul._result import RULPrediction
from pdmkit.rul._similarity import (
    HashSimilarityModel,
    PairwiseSimilarityModel,
    ResidualSimilarityModel,
)
from pdmkit.rul._survival import CovariateSurvivalModel, ReliabilitySurvivalModel
from pdmkit.rul._wiener import WienerDegradationModel
from pdmkit.rul._wiener_noise import NoisyWienerDegradationModel

__all__ = [
    "OOD_THRESHOLD",
    "BoostingRULModel",
    "ConformalRUL",
    "CovariateSurvivalModel",
    "ExponentialDegradationModel",
    "GammaProcessDegradationModel",
    "HashSimilarityModel",
    "HealthIndicator",
    "LinearDegradationModel",
    "NeuralRULModel",
    "NoisyWienerDegradationModel",
    "PairwiseSimilarityModel",
    "RULPipeline",
    "RULPrediction",
    "RegimeNormalizer",
    "ReliabilitySurvivalModel",
    "ResidualSimilarityModel",
    "WienerDegradationModel",
    "alpha_lambda_accuracy",
    "coverage_check",
    "interval_coverage",
    "mae",
    "ood_scores",
    "phm08_score",
    "prognostic_horizon",
    "prognostic_ranking",
    "relative_accuracy",
    "resolve_keys",
    "rmse",
    "rul_metrics",
    "shutdown_endings",
    "smooth_indicators",
    "timestamps_to_seconds",
]
