"""A trained RUL model answers a unit's RUL from its history: RULPipeline, the saved
``model.pdmkit`` of ``pdmkit rul`` and ``pdmkit rul --trained MODEL --history TABLE``."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.neighbors import KNeighborsClassifier

from pdmkit import load_model, save_model
from pdmkit.errors import ConvergenceWarning, DataError, ModelError
from pdmkit.experiments._cli import main
from pdmkit.experiments._rul import predict_rul
from pdmkit.rul import HealthIndicator, LinearDegradationModel, RULPipeline


@pytest.fixture(scope="module")
def tables_on_disk(tmp_path_factory, rul_tables_module):
    folder = tmp_path_factory.mktemp("tables")
    train, test = rul_tables_module(seed=3)
    train.to_csv(folder / "train.csv", index=False)
    test.to_parquet(folder / "test.parquet")
    return folder, train, test


def test_pipeline_equals_indicator_then_model(rul_tables):
    train, test = rul_tables(seed=1)
    pipe = RULPipeline(HealthIndicator(["s1", "s2"]), LinearDegradationModel())
    got = pipe.fit(train).predict(test).to_pandas()
    indicator = HealthIndicator(["s1", "s2"])
    model = LinearDegradationModel().fit(indicator.fit_transform(train))
    want = model.predict(indicator.transform(test)).to_pandas()
    pd.testing.assert_frame_equal(got, want)


def test_pipeline_needs_a_rul_model(rul_tables):
    with pytest.raises(TypeError, match="RUL model"):
        RULPipeline(None, KNeighborsClassifier()).fit(rul_tables()[0])


@pytest.mark.parametrize("model", ["similarity", "linear-degradation", "survival"])
def test_saved_model_answers_what_the_run_predicted(tables_on_disk, tmp_path, model):
    folder, _, test = tables_on_disk
    out = tmp_path / "run"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        code = main(
            [
                "rul",
                "--train",
                str(folder / "train.csv"),
                "--test",
                str(folder / "test.parquet"),
                "--model",
                model,
                "--out",
                str(out),
            ]
        )
    assert code == 0
    predicted = pd.read_parquet(out / "predictions.parquet").set_index("unit")
    # one unit's history, without the label column, as a user would have it
    unit = int(test["unit"].iloc[-1])
    history = test[test["unit"] == unit].drop(columns="rul_true_final")
    history.to_csv(tmp_path / "history.csv", index=False)
    answer_path = tmp_path / "answer.json"
    args = ["rul", "--trained", str(out / "model.pdmkit")]
    args += ["--history", str(tmp_path / "history.csv"), "--json", str(answer_path)]
    assert main(args) == 0
    answer = json.loads(answer_path.read_text())
    (row,) = answer["units"]
    assert row["unit"] == unit
    assert row["time"] == history["cycle"].max()
    for key in ("rul", "lower", "upper"):
        assert row[key] == pytest.approx(predicted.loc[unit, key], rel=1e-9)


def test_dataset_option_and_option_reach_the_workflow(tables_on_disk, tmp_path, capsys):
    folder, *_ = tables_on_disk
    args = ["rul", "--train", str(folder / "train.csv"), "--test"]
    args += [str(folder / "test.parquet"), "--model", "similarity", "--option", "k=3"]
    assert main([*args, "--json", str(tmp_path / "s.json"), "--out", str(tmp_path)]) == 0
    assert "k=3" in json.loads((tmp_path / "s.json").read_text())["estimator"]
    # an unknown simulation setting is named before anything is simulated
    code = main(["rul", "--dataset", "pneumatic-leak", "--dataset-option", "n_units=3"])
    assert code == 2 and "n_units" in capsys.readouterr().err


def test_bad_trained_inputs_are_named(tables_on_disk, tmp_path, capsys):
    folder, train, test = tables_on_disk
    pipe = RULPipeline(HealthIndicator(["s1", "s2"]), LinearDegradationModel())
    path = save_model(pipe.fit(train), tmp_path / "model.pdmkit")
    assert isinstance(load_model(path), RULPipeline)
    # a history without a column the indicator reads: the file and the column named
    history = test[test["unit"] == test["unit"].iloc[0]].drop(columns="s2")
    history.to_csv(tmp_path / "h.csv", index=False)
    with pytest.raises(DataError, match=r"h\.csv.*s2"):
        predict_rul(path, tmp_path / "h.csv")
    # without a unit column the file is one unit's history, named after the file
    one = test[test["unit"] == test["unit"].iloc[0]].drop(columns="unit")
    one.to_csv(tmp_path / "pump-7.csv", index=False)
    (row,) = predict_rul(path, tmp_path / "pump-7.csv")["units"]
    want = pipe.predict(one.assign(unit="pump-7")).estimate[0]
    assert row["unit"] == "pump-7" and row["rul"] == pytest.approx(want)
    # a model file that holds something else
    other = save_model(
        KNeighborsClassifier(1).fit(np.eye(2), [0, 1]), tmp_path / "knn.pdmkit"
    )
    with pytest.raises(ModelError, match="not a RUL model"):
        predict_rul(other, history)
    # not a model file at all, and half of the pair of options
    assert main(["rul", "--trained", str(folder / "train.csv"), "--history", "x"]) == 2
    assert "not a pdmkit model file" in capsys.readouterr().err
    assert main(["rul", "--trained", str(path)]) == 2
    assert "go together" in capsys.readouterr().err
    assert main(["rul", "--test", str(folder / "test.parquet")]) == 2
    assert "--test needs --train" in capsys.readouterr().err


def test_calibrate_keeps_estimates_and_rescales_intervals(tables_on_disk, tmp_path):
    folder, *_ = tables_on_disk
    args = ["rul", "--train", str(folder / "train.csv"), "--test"]
    args += [str(folder / "test.parquet"), "--model", "linear-degradation"]
    runs = {}
    for flag in ([], ["--calibrate"]):
        out = tmp_path / ("cal" if flag else "raw")
        assert main([*args, *flag, "--json", str(out / "s.json"), "--out", str(out)]) == 0
        runs[bool(flag)] = (
            json.loads((out / "s.json").read_text()),
            pd.read_parquet(out / "predictions.parquet"),
        )
    (raw, raw_pred), (cal, cal_pred) = runs[False], runs[True]
    assert not raw["calibrated"] and cal["calibrated"]
    factors = cal["interval_factors"]
    np.testing.assert_array_equal(cal_pred["rul"], raw_pred["rul"])
    np.testing.assert_allclose(
        cal_pred["upper"] - cal_pred["rul"],
        np.minimum(
            factors["upper"] * (raw_pred["upper"] - raw_pred["rul"]),
            125.0 - raw_pred["rul"],
        ),
        rtol=1e-9,
        atol=1e-9,
    )
