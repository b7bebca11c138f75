"""ConformalRUL: a model's intervals rescaled on held-out training units."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit import load_model, save_model
from pdmkit.errors import DataError
from pdmkit.rul import (
    ConformalRUL,
    HealthIndicator,
    LinearDegradationModel,
    RULPipeline,
    WienerDegradationModel,
)
from pdmkit.rul._conformal import _conformal_quantile


def _walks(rng, n, first=0, shape=16.0):
    """Monotone random walks (gamma steps) to 1.0 with unit-specific rates: a linear
    degradation model's straight line with iid noise is the wrong noise model here."""
    rows, lives = [], {}
    for u in range(first, first + n):
        rate = 1.0 / rng.uniform(24, 60)
        x = np.r_[0, np.cumsum(rng.gamma(shape, rate / shape, 400))]
        end = int(np.flatnonzero(x >= 1.0)[0])
        hi = x[: end + 1] + rng.normal(0, 0.005, end + 1)
        rows.append(pd.DataFrame({"unit": u, "time": np.arange(end + 1.0), "hi": hi}))
        lives[u] = end
    return pd.concat(rows, ignore_index=True), lives


@pytest.fixture(scope="module")
def fleet():
    rng = np.random.default_rng(0)
    train, _ = _walks(rng, 30)
    test, lives = _walks(rng, 200, first=1000)
    return train, test, lives


def _coverage(pred, lives):
    table = pred.to_pandas()
    true = np.array([lives[u] for u in table["unit"]]) - table["time"].to_numpy()
    keep = true > 0
    inside = (table["lower"] <= true) & (true <= table["upper"])
    return float(inside[keep].mean())


def test_quantile_has_the_finite_sample_correction():
    scores = np.arange(1.0, 10.0)  # 9 scores
    assert _conformal_quantile(scores, 0.9) == 9.0  # ceil(10 * 0.9) = 9th
    assert _conformal_quantile(scores, 0.5) == 5.0  # ceil(10 * 0.5) = 5th
    assert _conformal_quantile(scores, 0.95) == np.inf  # ceil(9.5) = 10 > 9
    assert _conformal_quantile(np.array([np.nan, 2.0, 1.0]), 0.5) == 2.0


def test_overconfident_intervals_become_calibrated_and_estimates_stay(fleet):
    train, test, lives = fleet
    plain = LinearDegradationModel(threshold=1.0).fit(train)
    calibrated = ConformalRUL(LinearDegradationModel(threshold=1.0)).fit(train)
    raw = plain.predict_trajectory(test, every=3)
    new = calibrated.predict_trajectory(test, every=3)
    assert _coverage(raw, lives) < 0.7  # the iid-noise line is far too sure
    assert 0.8 <= _coverage(new, lives) <= 0.98
    np.testing.assert_array_equal(new.estimate, raw.estimate)
    assert calibrated.upper_factor_ > 1 and calibrated.lower_factor_ > 1
    assert (new.lower >= 0).all() and new.level == pytest.approx(0.9)


def test_well_calibrated_model_stays_calibrated(fleet):
    train, test, lives = fleet
    model = ConformalRUL(WienerDegradationModel(threshold=1.0), level=0.8).fit(train)
    pred = model.predict_trajectory(test, every=3)
    assert 0.7 <= _coverage(pred, lives) <= 0.9
    assert model.scores_["rul_true"].min() >= 0


def test_scores_use_the_capped_truth(fleet):
    train, *_ = fleet
    model = ConformalRUL(LinearDegradationModel(threshold=1.0, max_rul=20.0)).fit(train)
    assert model.scores_["rul_true"].max() == 20.0
    assert model.scores_["rul"].max() <= 20.0


def test_in_a_pipeline_saved_and_loaded(fleet, tmp_path):
    train, test, _ = fleet
    table = train.assign(sensor=train["hi"] * 3 + 1)
    pipe = RULPipeline(
        HealthIndicator(["sensor"]), ConformalRUL(LinearDegradationModel(), n_folds=3)
    ).fit(table)
    some = test[test["unit"] < 1005].assign(sensor=lambda t: t["hi"] * 3 + 1)
    loaded = load_model(save_model(pipe, tmp_path / "conformal.pdmkit"))
    a, b = pipe.predict(some), loaded.predict(some)
    for key in ("estimate", "lower", "upper"):
        np.testing.assert_array_equal(getattr(b, key), getattr(a, key))


def test_bad_inputs_are_named(fleet):
    train, *_ = fleet
    with pytest.raises(TypeError, match="RUL model"):
        ConformalRUL(None).fit(train)
    with pytest.raises(DataError, match="at least 2 training units"):
        ConformalRUL(LinearDegradationModel(threshold=1.0)).fit(train[train["unit"] == 0])
    censored = train.assign(failed=False)
    with pytest.raises(DataError, match="ran to failure"):
        ConformalRUL(LinearDegradationModel(threshold=1.0), n_folds=2).fit(censored)
    with pytest.raises(ValueError, match="n_folds"):
        ConformalRUL(LinearDegradationModel(threshold=1.0), n_folds=1).fit(train)
