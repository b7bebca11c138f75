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
    on_disk = json.loads((tmp_path / "out" / "rul.json").read_text())
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
    with pytest.raises(DataError, match="rul_true_final"):
        run_rul((train, test.drop(columns="rul_true_final")), "similarity", tmp_path)
    assert not (tmp_path / "rul.json").exists()


def test_model_names_are_documented():
    assert {"similarity", "degradation", "survival", "neural"} <= set(RUL_MODELS)
