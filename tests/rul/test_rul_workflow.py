"""The RUL workflow (experiments/_rul.py) on small synthetic run-to-failure tables."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import ConvergenceWarning, DataError
from pdmkit.experiments._rul import RUL_MODELS, run_rul

KEYS = {"model", "rmse", "mae", "phm08_score", "n_units", "coverage"}


def _tables(seed=0, n_train=24, n_test=8):
    rng = np.random.default_rng(seed)

    def units(n, cut):
        rows = []
        for u in range(n):
            life = int(rng.integers(70, 120))
            t = np.arange(1, life + 1)
            stop = life - int(rng.integers(5, 50)) if cut else life
            frac = t / life
            rows.append(
                pd.DataFrame(
                    {
                        "unit": u + 1,
                        "cycle": t[:stop],
                        "setting_1": rng.normal(0, 1e-3, life)[:stop],
                        "s1": (frac**2 + rng.normal(0, 0.03, life))[:stop],
                        "s2": (1 - frac**3 + rng.normal(0, 0.03, life))[:stop],
                        "rul_true_final": life - stop,
                    }
                )
            )
        return pd.concat(rows, ignore_index=True)

    train = units(n_train, False).drop(columns="rul_true_final")
    return train, units(n_test, True)


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
def test_each_model_writes_json_report_and_predictions(tmp_path, model):
    with warnings.catch_warnings():
        # the noise-free synthetic indicator separates the failures almost perfectly
        warnings.simplefilter("ignore", ConvergenceWarning)
        out = run_rul(
            _tables(),
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
def test_neural_model_with_a_tiny_configuration(tmp_path):
    pytest.importorskip("torch")
    opts = {"window": 5, "hidden": 4, "epochs": 2, "n_folds": 2, "n_threads": 1}
    out = run_rul(_tables(), "neural", tmp_path, options=opts, n_trajectories=1)
    assert KEYS <= set(out) and out["n_units"] == 8


def test_similarity_is_accurate_on_easy_data(tmp_path):
    out = run_rul(_tables(), "similarity", tmp_path, n_trajectories=0)
    assert out["rmse"] < 15 and out["rmse_uncapped"] >= out["rmse"] - 1e-9


def test_bad_inputs_give_clear_errors(tmp_path):
    train, test = _tables()
    with pytest.raises(DataError, match="model must be one of"):
        run_rul((train, test), "kalman", tmp_path)
    with pytest.raises(DataError, match="not known"):
        run_rul("cmapss-fd004", "similarity", tmp_path)
    with pytest.raises(DataError, match="rul_true_final"):
        run_rul((train, test.drop(columns="rul_true_final")), "similarity", tmp_path)
    assert not (tmp_path / "rul.json").exists()


def test_model_names_are_documented():
    assert {"similarity", "degradation", "survival", "neural"} <= set(RUL_MODELS)
