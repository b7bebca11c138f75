"""Common checks every RUL estimator passes (scikit-learn protocol, pickling, errors)."""

from __future__ import annotations

import pickle

import numpy as np
import pandas as pd
import pytest
from sklearn.base import clone

from pdmkit.errors import DataError, NotFittedError
from pdmkit.rul import (
    CovariateSurvivalModel,
    ExponentialDegradationModel,
    HashSimilarityModel,
    LinearDegradationModel,
    NeuralRULModel,
    PairwiseSimilarityModel,
    ReliabilitySurvivalModel,
    ResidualSimilarityModel,
    RULPrediction,
)


def _fleet(seed=0, n=10):
    rng = np.random.default_rng(seed)
    rows = []
    for u in range(n):
        life = int(rng.integers(40, 70))
        t = np.arange(1.0, life + 1)
        rows.append(
            pd.DataFrame(
                {
                    "unit": f"u{u}",
                    "time": t,
                    "hi": 0.05 + (t / life) ** 1.5 + rng.normal(0, 0.02, life),
                }
            )
        )
    return pd.concat(rows, ignore_index=True)


ESTIMATORS = [
    LinearDegradationModel(),
    ExponentialDegradationModel(),
    ResidualSimilarityModel(k=3),
    PairwiseSimilarityModel(k=3),
    PairwiseSimilarityModel(k=3, distance="dtw"),
    HashSimilarityModel(k=3, window=5),
    ReliabilitySurvivalModel(),
    CovariateSurvivalModel("hi", penalizer=0.1),
    NeuralRULModel(window=5, hidden=4, epochs=1, n_folds=2),
]


@pytest.mark.parametrize("est", ESTIMATORS, ids=lambda e: type(e).__name__)
def test_common_estimator_behaviour(est, tmp_path):
    train = _fleet()
    test = train[train["time"] <= 30]
    model = clone(est)
    assert model.get_params() == est.get_params()
    with pytest.raises(NotFittedError):
        model.predict(test)
    assert model.fit(train) is model
    pred = model.predict(test)
    assert isinstance(pred, RULPrediction)
    assert list(pred.unit) == list(pd.unique(test["unit"]))
    assert np.array_equal(pred.time, np.full(len(pred), 30.0))
    finite = np.isfinite(pred.estimate)
    assert (pred.lower[finite] <= pred.estimate[finite]).all()
    assert (pred.estimate[finite] <= pred.upper[finite]).all()
    assert (pred.lower >= 0).all()
    # deterministic, and survives pickling (sklearn's clone of a fitted model too)
    again = pickle.loads(pickle.dumps(model)).predict(test)
    assert np.allclose(again.estimate, pred.estimate, equal_nan=True)
    # missing columns and empty tables give DataError
    with pytest.raises(DataError):
        model.predict(test.drop(columns="time"))
    with pytest.raises(DataError):
        model.predict(test.iloc[:0])


@pytest.mark.parametrize(
    "est",
    [e for e in ESTIMATORS if not isinstance(e, ReliabilitySurvivalModel)],  # reads no hi
    ids=lambda e: type(e).__name__,
)
def test_nan_values_are_reported_with_unit_and_time(est):
    train = _fleet()
    train.loc[5, "hi"] = np.nan
    with pytest.raises(DataError, match=r"unit 'u0'.*NaN"):
        clone(est).fit(train)


def test_unknown_keyword_arguments_are_rejected():
    with pytest.raises(TypeError):
        ResidualSimilarityModel(degre=2)
