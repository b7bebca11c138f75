"""The air-leak RUL workflow: `run_rul("pneumatic-leak")` on the pneumatic twin."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError
from pdmkit.experiments._rul import leak_accuracy, run_rul, simulate_leak_dataset

KEYS = {"model", "rmse", "mae", "phm08_score", "n_units", "coverage"}
SMALL = {"n_train": 8, "n_test": 6, "max_cycles": 24, "t_end": 2.0}


@pytest.fixture(scope="module")
def leak_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("leak")
    summary = run_rul(
        "pneumatic-leak",
        "linear-degradation",
        out,
        json_path=out / "x.json",
        dataset_options=SMALL,
        n_trajectories=2,
    )
    return out, summary


@pytest.mark.slow
def test_workflow_writes_json_report_and_predictions(leak_run):
    out, summary = leak_run
    assert KEYS <= set(summary)
    assert summary["dataset"] == "pneumatic-leak" and summary["n_units"] == 6
    assert {"of_rul", "of_life", "mean_of_life", "alpha_lambda"} <= set(
        summary["within_10pct"]
    )
    assert json.loads((out / "x.json").read_text())["rmse"] == pytest.approx(
        summary["rmse"]
    )
    assert (out / "report.html").read_text().count("<img") >= 2
    pred = pd.read_parquet(out / "predictions.parquet")
    assert pred["unit"].nunique() == 6
    # the headline scores are over the last half of each unit's life
    assert summary["n_predictions"] == int(pred["last_half"].sum())


@pytest.mark.slow
def test_chosen_indicator_is_the_best_ranked_and_tracks_the_leak(leak_run):
    out, summary = leak_run
    ranking = summary["indicator_ranking"]
    best = max(ranking, key=lambda name: ranking[name]["score"])
    assert summary["indicator"] == best
    assert summary["seed_indicator"]["score"] <= ranking[best]["score"]
    # the chosen indicator follows the (hidden) leak coefficient of the simulation
    train, _ = simulate_leak_dataset(cache_dir=out / "cache", **SMALL)
    r = np.corrcoef(train[best], np.log10(train["c_leak"]))[0, 1]
    assert abs(r) > 0.95


@pytest.mark.slow
def test_predictions_improve_towards_failure_and_mostly_fall_within_10pct(leak_run):
    out, summary = leak_run
    pred = pd.read_parquet(out / "predictions.parquet")
    pred = pred[pred["rul_true"] > 0]
    err = (pred["rul"] - pred["rul_true"]).abs()
    frac = pred["time"] / pred["life"]
    assert err[frac >= 0.75].mean() < err[frac < 0.25].mean()
    # the headline fraction recomputed from the written predictions
    last = pred[pred["last_half"]]
    inside = (last["rul"] - last["rul_true"]).abs() <= 0.1 * last["life"]
    assert summary["within_10pct"]["points_of_life"] == pytest.approx(inside.mean())
    assert inside.mean() > 0.6


@pytest.mark.slow
def test_cached_tables_are_read_back(tmp_path):
    opts = {"n_train": 2, "n_test": 1, "max_cycles": 6, "t_end": 0.5, "seed": 3}
    first = simulate_leak_dataset(cache_dir=tmp_path, **opts)
    assert len(list(tmp_path.glob("leak_*.parquet"))) == 1
    second = simulate_leak_dataset(cache_dir=tmp_path, **opts)
    for a, b in zip(first, second, strict=True):
        pd.testing.assert_frame_equal(a, b)
    # test units continue the training units' numbering
    assert set(first[0]["unit"]).isdisjoint(first[1]["unit"])


def test_leak_accuracy_by_hand():
    # unit 1, life 10: last half = times 5..9, true RUL 5..1
    # unit 2, life 8: last half = times 4..7, true RUL 4..1; prediction at t=6 off by 1
    unit = [1] * 5 + [2] * 4
    time = [5, 6, 7, 8, 9, 4, 5, 6, 7]
    pred = [5.6, 4.0, 3.0, 2.0, 1.0, 4.0, 3.0, 3.0, 1.0]
    acc = leak_accuracy(unit, time, pred, {1: 10, 2: 8})
    # unit 1: |0.6| <= 0.1 * 10 but > 0.1 * 5; unit 2: |1| > 0.1 * 8
    assert acc["of_life"].tolist() == [True, False]
    assert acc["of_rul"].tolist() == [False, False]
    assert acc["mean_of_life"].tolist() == [True, True]  # 0.12 <= 1, 0.25 <= 0.8
    assert acc["mae"].tolist() == pytest.approx([0.12, 0.25])
    assert acc["frac_of_life"].tolist() == pytest.approx([1.0, 0.75])
    assert acc["frac_of_rul"].tolist() == pytest.approx([0.8, 0.75])
    # alpha-lambda at half life: unit 1 at t = 5 (5.6 vs 5: 12 %), unit 2 at t = 4
    assert acc["alpha_lambda"].tolist() == [False, True]


def test_leak_accuracy_fails_units_without_an_early_prediction():
    acc = leak_accuracy([1, 1], [8, 9], [2.0, 1.0], {1: 10})
    assert not acc.loc[1, ["of_rul", "of_life", "mean_of_life", "alpha_lambda"]].any()
    with pytest.raises(DataError, match="no life"):
        leak_accuracy([1, 2], [8, 9], [2.0, 1.0], {1: 10})
    none = leak_accuracy([1], [2], [2.0], {1: 10})  # nothing in the last half
    assert none.loc[1, "n"] == 0 and not none.loc[1, ["of_life", "of_rul"]].any()


def test_unknown_dataset_option_is_named(tmp_path):
    with pytest.raises(DataError, match="n_units"):
        run_rul(
            "pneumatic-leak", "linear-degradation", tmp_path, dataset_options={"n_units": 3}
        )


@pytest.mark.slow
def test_linear_degradation_meets_the_issue_target_on_the_default_leak_runs(tmp_path):
    # issue 6: linear-degradation RUL within 10 % over the last half of life for at
    # least 80 % of test units, on the default air-leak runs with 20 test units instead
    # of 40 (seed 0; the documented run on all 40 is
    # benchmarks/leak_rul.py, docs/rul.md; here 0.90 of the 20, 111 s CPU, almost all
    # of it simulating the twin's 40 units, against 157 s for 60).
    # the three models share one simulated fleet (the cache)
    cache = {"cache_dir": tmp_path / "cache", "n_test": 20}
    summary = run_rul(
        "pneumatic-leak",
        "linear-degradation",
        tmp_path / "linear",
        n_trajectories=0,
        dataset_options=cache,
    )
    assert summary["simulation"]["walk_shape"] == 16.0
    assert summary["n_units"] == 20
    assert summary["within_10pct"]["of_life"] >= 0.8
    # the residual and pairwise similarity models are reported beside it
    for model in ("similarity", "pairwise"):
        other = run_rul(
            "pneumatic-leak",
            model,
            tmp_path / model,
            n_trajectories=0,
            dataset_options=cache,
        )
        assert other["n_units"] == 20 and np.isfinite(other["rmse"])
