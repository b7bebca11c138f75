"""Prognostic metrics against hand-computed values (Saxena et al. 2008, 2010)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pdmkit.errors import DataError
from pdmkit.rul import (
    alpha_lambda_accuracy,
    interval_coverage,
    mae,
    phm08_score,
    prognostic_horizon,
    relative_accuracy,
    rmse,
    rul_metrics,
)


def test_rmse_and_mae_by_hand():
    true = [10, 20, 30, 40]
    pred = [11, 19, 33, 37]  # errors 1, -1, 3, -3
    assert rmse(true, pred) == pytest.approx(math.sqrt((1 + 1 + 9 + 9) / 4))
    assert mae(true, pred) == pytest.approx(2.0)


def test_phm08_score_by_hand():
    # d = pred - true: -13 (early), 0, +10 (late): (e - 1) + 0 + (e - 1)
    assert phm08_score([50, 50, 50], [37, 50, 60]) == pytest.approx(2 * (math.e - 1))


def test_phm08_score_punishes_late_more_than_early():
    early = phm08_score([100], [80])
    late = phm08_score([100], [120])
    assert early == pytest.approx(math.exp(20 / 13) - 1)
    assert late == pytest.approx(math.exp(2) - 1)
    assert late > early


def test_phm08_score_is_a_sum_over_units():
    one = phm08_score([30], [45])
    assert phm08_score([30] * 7, [45] * 7) == pytest.approx(7 * one)


def test_interval_coverage_by_hand():
    assert interval_coverage([10, 20, 30, 40], [5, 21, 30, 35], [15, 25, 35, 39]) == 0.5


def test_interval_coverage_rejects_crossed_intervals():
    with pytest.raises(DataError, match="lower is above upper"):
        interval_coverage([1.0], [2.0], [1.0])


def test_alpha_lambda_accuracy_by_hand():
    # eol 200, first prediction at 100: t_lambda = 100 + lam * 100
    time = [100, 120, 150, 180]
    pred = [90, 85, 62, 12]  # true RUL 100, 80, 50, 20
    # lam 0.5 -> t = 150: 62 vs 50, outside +-20 % (40..60)
    # lam 0.2 -> t = 120: 85 vs 80, inside
    out = alpha_lambda_accuracy(time, pred, 200, alpha=0.2, lam=[0.2, 0.5, 0.8])
    assert out.tolist() == [True, False, False]
    assert alpha_lambda_accuracy(time, pred, 200, alpha=0.25, lam=0.5) is True  # 62 <= 62.5


def test_alpha_lambda_uses_latest_prediction_before_t_lambda():
    # t_lambda = 0 + 0.5 * 100 = 50: the latest prediction at or before 50 is the one at 40
    assert alpha_lambda_accuracy([0, 40, 60], [100, 60, 10], 100, alpha=0.01, lam=0.5)


def test_relative_accuracy_by_hand():
    # lam 0.5 -> t = 150, true 50, predicted 62: 1 - 12 / 50
    assert relative_accuracy([100, 120, 150, 180], [90, 85, 62, 12], 200) == pytest.approx(
        0.76
    )


def test_prognostic_horizon_by_hand():
    # eol 100, alpha 0.1: band +-10; errors 30, 2, 12, 4, 1 -> inside from t = 60
    assert (
        prognostic_horizon([0, 20, 40, 60, 80], [130, 78, 72, 44, 19], 100, alpha=0.1) == 40
    )
    # always inside -> from the first prediction
    assert prognostic_horizon([10, 50], [90, 50], 100, alpha=0.05) == 90
    # last prediction outside -> no horizon
    assert prognostic_horizon([10, 50], [90, 70], 100, alpha=0.05) == 0


def test_trajectory_metrics_validate_input():
    with pytest.raises(DataError, match="strictly increasing"):
        prognostic_horizon([0, 0], [1, 1], 10)
    with pytest.raises(DataError, match="eol"):
        relative_accuracy([0, 50], [1, 1], 20)


def test_rul_metrics_collects_everything():
    m = rul_metrics([10, 20], [13, 16], lower=[5, 17], upper=[15, 18])
    assert m["rmse"] == pytest.approx(math.sqrt(12.5))
    assert m["mae"] == pytest.approx(3.5)
    assert m["bias"] == pytest.approx(-0.5)
    assert m["coverage"] == 0.5
    assert m["mean_width"] == pytest.approx(5.5)
    assert m["phm08_score"] == pytest.approx(math.expm1(0.3) + math.expm1(4 / 13))
    assert m["n"] == 2


def test_metrics_reject_mismatched_or_nan_input():
    with pytest.raises(DataError, match="one prediction per true RUL"):
        rmse([1, 2], [1])
    with pytest.raises(DataError, match="NaN"):
        mae([1, np.nan], [1, 2])


def test_infinite_prediction_gives_infinite_error():
    assert rmse([10.0], [np.inf]) == np.inf
