"""The RUL workflow (experiments/_rul.py) on small synthetic run-to-failure tables."""

from __future__ import annotations

import json
import warnings

import pandas as pd
import pytest

from pdmkit.errors import ConvergenceWarning, DataError
from pdmkit.experiments._rul import RUL_MODELS, run_rul

KEYS = {"model", "rmse", "mae", "phm08_score", "n_units", "coverage"}


@pytest.mark.parametrize(
    "model",
    [
        "similarity",
        "pairwise",
        "hash",
        "degradation",
        "linear-degradation",
        "survival",
        "covariate",
    ],
)
def test_each_model_writes_json_report_and_predictions(tmp_path, model, rul_tables):
    with warnings.catch_warnings():
        # the noise-free synthetic indicator separates the failures almost perfectly
        warnings.simplefilter("ignore", ConvergenceWarning)
        out = run_rul(
            rul_tables(),
            model,
            tmp_path / "out",
            json_path=tmp_path / "x.json",
            n_trajectories=1,
        )
    assert KEYS <= set(out)
    assert out["n_units"] == 8 and out["model"] == model
    assert out["features"] and "setting_1" not in out["features"]
    on_disk = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert on_disk["rmse"] == pytest.approx(out["rmse"])
    assert json.loads((tmp_path / "x.json").read_text())["model"] == model
    pred = pd.read_parquet(tmp_path / "out" / "predictions.parquet")
    assert len(pred) == 8 and {"rul", "lower", "upper", "rul_true"} <= set(pred.columns)
    assert (tmp_path / "out" / "report.html").read_text().count("<img") >= 2


@pytest.mark.torch
def test_neural_model_with_a_tiny_configuration(tmp_path, rul_tables):
    pytest.importorskip("torch")
    opts = {"window": 5, "hidden": 4, "epochs": 2, "n_folds": 2, "n_threads": 1}
    out = run_rul(rul_tables(), "neural", tmp_path, options=opts, n_trajectories=1)
    assert KEYS <= set(out) and out["n_units"] == 8


def test_similarity_is_accurate_on_easy_data(tmp_path, rul_tables):
    out = run_rul(rul_tables(), "similarity", tmp_path, n_trajectories=0)
    assert out["rmse"] < 15 and out["rmse_uncapped"] >= out["rmse"] - 1e-9


def test_bad_inputs_give_clear_errors(tmp_path, rul_tables):
    train, test = rul_tables()
    with pytest.raises(DataError, match="model must be one of"):
        run_rul((train, test), "kalman", tmp_path)
    with pytest.raises(DataError, match="not known"):
        run_rul("cmapss-fd004", "similarity", tmp_path)
    with pytest.raises(DataError, match="did you mean 'degree'"):
        run_rul((train, test), "similarity", tmp_path, options={"degre": 2})
    with pytest.raises(DataError, match="simulation settings of 'pneumatic-leak'"):
        run_rul((train, test), "similarity", tmp_path, dataset_options={"n_test": 3})
    with pytest.raises(DataError, match="rul_true_final"):
        run_rul((train, test.drop(columns="rul_true_final")), "similarity", tmp_path)
    assert not (tmp_path / "summary.json").exists()


def test_model_names_are_documented():
    assert {"similarity", "degradation", "survival", "neural"} <= set(RUL_MODELS)


def test_split_holds_out_cut_units_with_their_true_rul(rul_tables):
    from pdmkit.experiments import split_run_to_failure

    full, _ = rul_tables(n_train=20)
    train, test = split_run_to_failure(full, seed=4)
    held = set(test["unit"])
    assert len(held) == 5 and held.isdisjoint(train["unit"])
    assert held | set(train["unit"]) == set(full["unit"])
    life = full.groupby("unit")["cycle"].agg(["min", "max"])
    for u, part in test.groupby("unit"):
        first, last = life.loc[u]
        cut = part["cycle"].max()
        # the remaining life is what the unit had left after the cut
        assert part["rul_true_final"].iloc[0] == last - cut
        assert 0.1 * (last - first) <= cut - first <= 0.9 * (last - first) + 1
        # the history is the unit's first rows, unchanged
        pd.testing.assert_frame_equal(
            part.drop(columns="rul_true_final").reset_index(drop=True),
            full[(full["unit"] == u) & (full["cycle"] <= cut)].reset_index(drop=True),
        )
    again = split_run_to_failure(full, seed=4)
    pd.testing.assert_frame_equal(again[1], test)


def test_split_errors_are_named(rul_tables):
    from pdmkit.experiments import split_run_to_failure

    full, _ = rul_tables(n_train=5)
    with pytest.raises(DataError, match="at least 3"):
        split_run_to_failure(full[full["unit"] <= 2])
    with pytest.raises(ValueError, match="test_fraction"):
        split_run_to_failure(full, test_fraction=1.0)
    with pytest.raises(ValueError, match="cut"):
        split_run_to_failure(full, cut=(0.5, 0.2))
    # few units: at least one held out, at least two kept
    train, test = split_run_to_failure(full.loc[full["unit"] <= 3], test_fraction=0.9)
    assert test["unit"].nunique() == 1 and train["unit"].nunique() == 2


def test_cli_train_alone_holds_out_a_quarter(rul_tables, tmp_path):
    from pdmkit.experiments._cli import main

    full, _ = rul_tables(n_train=16)
    full.to_csv(tmp_path / "units.csv", index=False)
    args = ["rul", "--train", str(tmp_path / "units.csv"), "--model", "similarity"]
    assert main([*args, "--json", str(tmp_path / "s.json"), "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary["n_units"] == 4 and summary["n_train_units"] == 12
