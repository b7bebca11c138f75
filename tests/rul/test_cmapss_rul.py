"""RUL models on the real NASA C-MAPSS FD001 benchmark (skipped without the data).

Split: the 100 training engines (run to failure) train; the 100 test engines are
predicted at their last cycle and scored against RUL_FD001.txt, with predictions and
true RULs capped at 125 cycles as the literature does. Targets (issue 6): RMSE <= 20
for the best similarity model, <= 14 for the learned model (the full neural training
takes minutes: `pdmkit.experiments._rul.run_rul(model="neural")`, see docs/rul.md).
"""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
import scipy.stats

from pdmkit.rul import (
    ExponentialDegradationModel,
    HashSimilarityModel,
    HealthIndicator,
    NeuralRULModel,
    PairwiseSimilarityModel,
    ReliabilitySurvivalModel,
    ResidualSimilarityModel,
    rul_metrics,
)

pytestmark = pytest.mark.real_data
CAP = 125.0
SENSORS = [f"sensor_{i}" for i in range(1, 22)]


@functools.lru_cache(maxsize=1)
def _data():
    from pdmkit.ensembles import load_cmapss

    train = load_cmapss("FD001", "train")
    test = load_cmapss("FD001", "test")
    true = test.groupby("unit")["rul_true_final"].first()
    return train, test, true


@functools.lru_cache(maxsize=2)
def _indicator(smoothing):
    train, test, _ = _data()
    hi = HealthIndicator(SENSORS, smoothing=smoothing).fit(train)
    return hi, hi.transform(train), hi.transform(test)


def _score(pred):
    _, _, true = _data()
    truth = np.minimum(true.loc[pred.unit].to_numpy(dtype=float), CAP)
    return rul_metrics(truth, pred.estimate, pred.lower, pred.upper)


def test_health_indicator_drops_the_constant_sensors(require_data):
    require_data("cmapss_fd001")
    hi, train_hi, _ = _indicator(None)
    # FD001 runs at one operating condition: these six sensors never change
    assert sorted(hi.dropped_) == sorted(
        ["sensor_1", "sensor_5", "sensor_10", "sensor_16", "sensor_18", "sensor_19"]
    )
    # fitted to the fraction of life used: the average path climbs from about 0 to 1
    ends = train_hi.groupby("unit")["hi"].agg(["first", "last"]).mean()
    assert ends["last"] - ends["first"] > 0.6
    frac = train_hi["cycle"] / train_hi.groupby("unit")["cycle"].transform("max")
    assert np.corrcoef(frac, train_hi["hi"])[0, 1] > 0.8


@pytest.mark.parametrize(
    "model",
    [
        ResidualSimilarityModel(degree=3, k=10, max_rul=CAP),
        PairwiseSimilarityModel(k=10, max_rul=CAP),
        HashSimilarityModel(k=10, max_rul=CAP),
    ],
    ids=lambda m: type(m).__name__,
)
def test_similarity_models_meet_the_rmse_target(require_data, model):
    require_data("cmapss_fd001")
    _, train_hi, test_hi = _indicator(None)
    score = _score(model.fit(train_hi).predict(test_hi))
    assert score["n"] == 100
    assert score["rmse"] <= 20.0, score
    assert 0.7 <= score["coverage"] <= 1.0, score


def test_weibull_reliability_on_the_training_lifetimes(require_data):
    require_data("cmapss_fd001")
    train, test, _ = _data()
    lifetimes = train.groupby("unit")["cycle"].max().to_numpy(dtype=float)
    model = ReliabilitySurvivalModel(max_rul=CAP).fit(train)
    shape, _, scale = scipy.stats.weibull_min.fit(lifetimes, floc=0)
    assert model.params_["shape"] == pytest.approx(shape, rel=1e-3)
    assert model.params_["scale"] == pytest.approx(scale, rel=1e-3)
    score = _score(model.predict(test))
    assert score["n"] == 100 and np.isfinite(score["rmse"])


def test_exponential_degradation_runs_on_the_smoothed_indicator(require_data):
    require_data("cmapss_fd001")
    _, train_hi, test_hi = _indicator(10)
    model = ExponentialDegradationModel(max_rul=CAP).fit(train_hi)
    pred = model.predict(test_hi)
    assert np.isfinite(pred.estimate).all()
    # a misfit on C-MAPSS (flat, then rising paths; see docs/rul.md), kept from worsening
    assert _score(pred)["rmse"] < 60


@pytest.mark.slow
@pytest.mark.torch
def test_small_neural_model_learns_on_cmapss(require_data):
    require_data("cmapss_fd001")
    pytest.importorskip("torch")
    train, test, _ = _data()
    units = train["unit"].unique()[::2]  # half the engines, a few epochs: a smoke test
    # 8 epochs: with 4 the RMSE spread 22.7-28.7 over seeds 0-3 once the two sensors
    # constant up to rounding (1e-15 spread) stopped entering as standardised noise;
    # with 8, 18.8-19.6
    model = NeuralRULModel(SENSORS, hidden=32, epochs=8, n_folds=2, n_threads=1)
    pred = model.fit(train[train["unit"].isin(units)]).predict(test)
    assert _score(pred)["rmse"] < 25


@pytest.mark.slow
def test_run_rul_writes_json_and_report(require_data, tmp_path):
    require_data("cmapss_fd001")
    from pdmkit.experiments._rul import run_rul

    out = run_rul("cmapss-fd001", "similarity", tmp_path / "out", tmp_path / "s.json")
    assert {"model", "rmse", "mae", "phm08_score", "n_units", "coverage"} <= set(out)
    assert out["n_units"] == 100 and out["rmse"] <= 20
    assert json.loads((tmp_path / "s.json").read_text())["rmse"] == pytest.approx(
        out["rmse"]
    )
    html = (tmp_path / "out" / "report.html").read_text()
    assert html.count("<img") >= 3
