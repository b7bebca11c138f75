"""``pdmkit rul --train TABLE --cv units|K`` (issue 32): cross-validation by unit on a
user's own run-to-failure table, through the code path of the NASA cells'
leave-one-cell-out.

Five units, four that fail after about 100 cycles and one (``E``) after 300: a model
that saw ``E`` expects long lives, one that did not expects ``E`` to fail near cycle
100. ``E``'s cross-validated predictions must be those of a model trained on the four
others (built here, independently of the workflow) and not those of a model trained on
all five.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest

from pdmkit.experiments._cli import main
from pdmkit.experiments._rul_cv import unit_folds
from pdmkit.rul import ReliabilitySurvivalModel, RULPipeline, rul_metrics

LIVES = {"A": 95, "B": 105, "C": 100, "D": 110, "E": 300}


def _fleet() -> pd.DataFrame:
    rng = np.random.default_rng(3)
    rows = []
    for unit, life in LIVES.items():
        t = np.arange(1, life + 1)
        s1 = (t / life) ** 2 + rng.normal(0, 0.02, life)
        s2 = 1 - t / life + rng.normal(0, 0.02, life)
        rows.append(pd.DataFrame({"unit": unit, "cycle": t, "s1": s1, "s2": s2}))
    return pd.concat(rows, ignore_index=True)


@pytest.fixture(scope="module")
def cv_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cv")
    table = _fleet()
    table.to_csv(folder / "fleet.csv", index=False)
    out = folder / "out"
    args = ["rul", "--train", str(folder / "fleet.csv"), "--cv", "units"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main([*args, "--model", "survival", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    return table, summary, pd.read_parquet(out / "predictions.parquet"), caught, out


def test_five_units_five_folds_each_unit_held_out_once(cv_run):
    _, summary, predictions, _, out = cv_run
    cv = summary["cv"]
    assert cv["scheme"] == "leave one unit out" and cv["n_folds"] == 5
    assert sorted(u for f in cv["folds"] for u in f["units"]) == sorted(LIVES)
    assert all(len(f["units"]) == 1 and f["n_train_units"] == 4 for f in cv["folds"])
    fold_of = {f["units"][0]: f["fold"] for f in cv["folds"]}
    # every prediction of a unit comes from the fold that held it out
    for unit, part in predictions.groupby("unit"):
        assert set(part["fold"]) == {fold_of[unit]}
    assert set(predictions["unit"]) == set(LIVES)
    assert (out / "model.pdmkit").is_file() and (out / "report.html").is_file()


def test_odd_unit_is_predicted_by_a_model_that_never_saw_it(cv_run):
    table, summary, predictions, _, _ = cv_run
    odd = table[table["unit"] == "E"]
    every = summary["cv"]["every"]
    without = RULPipeline(None, ReliabilitySurvivalModel()).fit(table[table.unit != "E"])
    with_it = RULPipeline(None, ReliabilitySurvivalModel()).fit(table)
    expected = without.predict_trajectory(odd, every=every).to_pandas()
    seen = with_it.predict_trajectory(odd, every=every).to_pandas()
    got = predictions[predictions["unit"] == "E"].reset_index(drop=True)
    np.testing.assert_allclose(got["time"], expected["time"])
    np.testing.assert_allclose(got["rul"], expected["rul"], rtol=1e-9, atol=1e-9)
    # and not a model that saw it: that one expects E to live on
    assert np.mean(np.abs(seen["rul"] - got["rul"])) > 30
    # E held out: the other units' lives say it fails near cycle 100
    late = got[got["time"] >= 150]
    assert late["rul"].max() < 5 and (300 - late["time"]).mean() > 50


def test_cv_metrics_in_the_summary_follow_from_the_predictions(cv_run):
    _, summary, predictions, _, _ = cv_run
    life = predictions["unit"].map(LIVES)
    scored = predictions[(predictions["time"] >= life / 2) & (predictions["time"] < life)]
    true = life[scored.index] - scored["time"]
    assert np.allclose(scored["rul_true"], true)
    m = rul_metrics(true, scored["rul"], scored["lower"], scored["upper"])
    rmse = float(np.sqrt(np.mean((scored["rul"] - true) ** 2)))
    assert summary["rmse"] == pytest.approx(rmse, rel=1e-12) == m["rmse"]
    assert summary["mae"] == pytest.approx(np.mean(np.abs(scored["rul"] - true)))
    inside = (scored["lower"] <= true) & (true <= scored["upper"])
    assert summary["coverage"] == pytest.approx(inside.mean())
    assert summary["n_predictions"] == len(scored) and summary["n_units"] == 5
    assert summary["per_unit"]["E"]["life"] == 300


def test_cv_coverage_far_below_its_level_is_warned(cv_run):
    _, summary, _, caught, _ = cv_run
    check = summary["coverage_check"]
    assert check["far_below"] and check["n"] == 5 and check["coverage"] < 0.6
    said = [str(w.message) for w in caught if "intervals covered" in str(w.message)]
    assert len(said) == 1 and said[0].startswith("90 % intervals covered 49 %")
    assert said[0] in " ".join(summary["warnings"])


def test_k_folds_partition_the_units(tmp_path):
    folds = unit_folds(list(LIVES), 2, seed=1)
    assert len(folds) == 2 and sorted(u for f in folds for u in f) == sorted(LIVES)
    assert sorted(map(len, folds)) == [2, 3]
    assert unit_folds(list(LIVES), "3", seed=1) == unit_folds(list(LIVES), 3, seed=1)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--cv", "1"], "number of folds >= 2"),
        (["--cv", "7"], "cv=7 folds need 2 to 5 folds"),
        (["--cv", "units", "--test", "x.csv"], "--cv cross-validates the units"),
    ],
)
def test_cv_mistakes_are_one_line_errors(tmp_path, capsys, extra, message):
    _fleet().to_csv(tmp_path / "fleet.csv", index=False)
    args = ["rul", "--train", str(tmp_path / "fleet.csv"), "--out", str(tmp_path / "o")]
    try:
        code = main([*args, "--model", "survival", *extra])
    except SystemExit as exc:  # argparse refuses a bad --cv value itself
        code = exc.code
    assert code == 2
    assert message in capsys.readouterr().err
