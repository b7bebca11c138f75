"""Edge cases of issue 6 not covered per model elsewhere: short units and histories,
units past every training failure, and censored units in the degradation prior."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit.rul import (
    LinearDegradationModel,
    PairwiseSimilarityModel,
    ResidualSimilarityModel,
)


@pytest.fixture
def fleet():
    rng = np.random.default_rng(0)
    rows = []
    for u, life in enumerate([30, 40, 50, 35, 45, 38]):
        t = np.arange(1.0, life + 1)
        rows.append(
            pd.DataFrame({"unit": u, "time": t, "hi": t / life + rng.normal(0, 0.02, life)})
        )
    return pd.concat(rows, ignore_index=True)


def test_training_units_too_short_for_a_line_are_left_out_of_the_prior(fleet):
    # a straight line through 2 samples has no residual: the unit tells nothing about
    # the noise or the spread of slopes, so the prior is the one without it
    short = pd.DataFrame({"unit": 99, "time": [1.0, 2.0], "hi": [0.1, 0.9]})
    with_short = LinearDegradationModel().fit(pd.concat([fleet, short]))
    without = LinearDegradationModel().fit(fleet)
    np.testing.assert_allclose(with_short.prior_mean_, without.prior_mean_)
    np.testing.assert_allclose(with_short.prior_cov_, without.prior_cov_)
    assert with_short.noise_var_ == pytest.approx(without.noise_var_)
    assert with_short.threshold_ == pytest.approx(without.threshold_)
    assert 99 not in set(with_short.unit_params_["unit"])


def test_censored_units_shape_the_prior_when_the_threshold_is_given(fleet):
    # censoring a unit (cutting its history) still leaves a usable line for the prior
    cut = fleet[(fleet["unit"] != 2) | (fleet["time"] <= 25)].copy()
    cut["failed"] = cut["unit"] != 2
    model = LinearDegradationModel(threshold=1.0).fit(cut)
    assert 2 in set(model.unit_params_["unit"]) and model.n_units_ == 6
    assert np.isfinite(model.predict(cut[cut["unit"] == 2]).estimate).all()


@pytest.mark.parametrize(
    "est",
    [
        ResidualSimilarityModel(),
        PairwiseSimilarityModel(),
        PairwiseSimilarityModel(align="start"),
        LinearDegradationModel(),
    ],
    ids=["residual", "pairwise", "pairwise-start", "linear"],
)
def test_a_unit_past_every_training_failure_gets_zero(fleet, est):
    # a history that has gone beyond the failure state of every training unit
    t = np.arange(1.0, 71.0)
    overdue = pd.DataFrame({"unit": "late", "time": t, "hi": t / 50})
    pred = est.fit(fleet).predict(overdue)
    assert pred.estimate[0] == pytest.approx(0.0, abs=0.5)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_pairwise_window_longer_than_the_history_uses_all_of_it(fleet, n):
    history = fleet[fleet["unit"] == 0].head(n).assign(unit="new")
    windowed = PairwiseSimilarityModel(window=10).fit(fleet).predict(history)
    whole = PairwiseSimilarityModel().fit(fleet).predict(history)
    np.testing.assert_allclose(windowed.estimate, whole.estimate)
    np.testing.assert_allclose(windowed.upper, whole.upper)


def test_one_sample_histories_give_finite_estimates_within_the_training_lives(fleet):
    # a brand-new unit: the similarity and degradation models fall back on the fleet
    first = pd.DataFrame({"unit": ["new"], "time": [1.0], "hi": [0.03]})
    lives = fleet.groupby("unit")["time"].max()
    for est in (ResidualSimilarityModel(), PairwiseSimilarityModel()):
        pred = est.fit(fleet).predict(first)
        assert lives.min() - 1 <= pred.estimate[0] <= lives.max() - 1
    lin = LinearDegradationModel().fit(fleet).predict(first)
    assert np.isfinite(lin.estimate[0]) and lin.lower[0] < lin.estimate[0] < lin.upper[0]


def test_residual_model_lowers_the_degree_for_training_units_shorter_than_it():
    # a 3-sample training unit cannot carry a cubic: it gets the quadratic through its
    # points, so a history equal to it matches it exactly (residual 0, remaining life 0)
    t = np.arange(1.0, 4.0)
    train = pd.DataFrame(
        {
            "unit": np.repeat([1, 2], [3, 20]),
            "time": np.r_[t, np.arange(1.0, 21.0)],
            "hi": np.r_[[0.1, 0.5, 0.6], np.linspace(0, 1, 20)],
        }
    )
    history = train[train["unit"] == 1].assign(unit="copy")
    pred = ResidualSimilarityModel(k=1, degree=3).fit(train).predict(history)
    assert tuple(pred.extra["nearest"][0]) == (1,)
    assert pred.estimate[0] == pytest.approx(0.0)
