"""The coverage warning (issue 32): intervals far below their level on held-out units.

The rule (:func:`pdmkit.rul.coverage_check`): coverage more than 5 points below the
level and a one-sided exact binomial test at 1 %. The p-value is checked against the
binomial sum written out here; the warning against a case that is far below (a
degradation model's narrow intervals on held-out units) and one that is not (the same
data, the similarity model).
"""

from __future__ import annotations

import math
import tempfile
import warnings

import numpy as np
import pytest

from pdmkit.experiments._rul import run_rul
from pdmkit.rul import RULPrediction, coverage_check


def _binomial_cdf(k: int, n: int, p: float) -> float:
    return sum(math.comb(n, i) * p**i * (1 - p) ** (n - i) for i in range(k + 1))


def _case(n: int, covered: int):
    """``n`` true RULs of 10, the first ``covered`` inside their intervals."""
    true = np.full(n, 10.0)
    lower = np.where(np.arange(n) < covered, 5.0, 11.0)
    return true, lower, np.full(n, 20.0)


def test_far_below_warns_with_the_numbers():
    true, lower, upper = _case(100, 11)
    with pytest.warns(UserWarning) as caught:
        check = coverage_check(true, lower, upper, 0.9)
    (message,) = [str(w.message) for w in caught]
    assert message.startswith("90 % intervals covered 11 % of held-out units' true RUL")
    assert "11 of 100" in message and "\n" not in message
    assert check["far_below"] and check["n_covered"] == 11
    assert check["p_value"] == pytest.approx(_binomial_cdf(11, 100, 0.9), rel=1e-9)


@pytest.mark.parametrize(
    ("n", "covered", "far"),
    [
        (5, 2, True),  # P(X <= 2 | 5, 0.9) = 0.0086 < 0.01
        (5, 3, False),  # 0.081: three of five is not evidence enough
        (100, 85, False),  # 0.073: a few points short, not significant
        (1000, 870, False),  # significant (p ~ 1e-3), but within 5 points
        (1000, 840, True),
        (20, 20, False),
    ],
)
def test_the_rule_binomial_and_tolerance(n, covered, far):
    true, lower, upper = _case(n, covered)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check = coverage_check(true, lower, upper, 0.9)
    assert check["far_below"] is far
    assert len(caught) == int(far)
    expected = _binomial_cdf(covered, n, 0.9)
    assert check["p_value"] == pytest.approx(expected, rel=1e-6, abs=1e-300)
    assert (check["p_value"] < 0.01 and covered / n < 0.85) is far


def test_trajectories_are_tested_on_their_units():
    # 200 predictions along 4 units' lives, 40 % covered: as 200 draws it would be
    # damning, as 4 units (about 2 covered) it is not evidence
    true, lower, upper = _case(200, 80)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check = coverage_check(true, lower, upper, 0.9, n_units=4)
    assert check["n"] == 4 and check["n_covered"] == 2 and not check["far_below"]
    assert check["p_value"] == pytest.approx(_binomial_cdf(2, 4, 0.9))


def test_evaluate_warns_on_far_too_narrow_intervals():
    true, lower, upper = _case(30, 3)
    bad = RULPrediction(np.arange(30), np.ones(30), true, lower, upper)
    with pytest.warns(UserWarning, match="covered 10 % of the scored units' true RUL"):
        assert bad.evaluate(true)["coverage"] == pytest.approx(0.1)
    good = RULPrediction(np.arange(30), np.ones(30), true, *_case(30, 28)[1:])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert good.evaluate(true)["coverage"] == pytest.approx(28 / 30)


@pytest.mark.parametrize(
    ("model", "far"), [("linear-degradation", True), ("similarity", False)]
)
def test_workflow_warns_on_held_out_units_only_when_far_below(rul_tables, model, far):
    train, test = rul_tables(seed=0, n_train=16, n_test=20)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        summary = run_rul((train, test), model, tempfile.mkdtemp(), n_trajectories=0)
    check = summary["coverage_check"]
    assert check["coverage"] == summary["coverage"] and check["n"] == 20
    assert check["far_below"] is far
    said = [str(w.message) for w in caught if "intervals covered" in str(w.message)]
    assert len(said) == int(far)
    assert any("intervals covered" in w for w in summary["warnings"]) is far
    if far:  # linear-degradation: 15 % of 20 held-out units inside 90 % intervals
        assert said[0].startswith(
            f"90 % intervals covered {100 * summary['coverage']:.0f} % of held-out"
        )
        assert summary["coverage"] < 0.5
