"""``pdmkit rul`` for real users (issue 32): the answers of ``--trained`` written to
``--out``, and C-MAPSS's own test layout scored with ``--test-rul``.

The written predictions are checked against the same model's in-process prediction, and
the C-MAPSS scores against a plain pandas computation from the written predictions and
NASA's RUL file (RMSE, and the PHM08 score of Saxena et al. 2008, eq. 1).
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings

import numpy as np
import pandas as pd
import pytest

from pdmkit import load_model, save_model
from pdmkit._outputs import OUTPUTS
from pdmkit.errors import DataError
from pdmkit.experiments._cli import main
from pdmkit.experiments._rul_tables import with_true_rul
from pdmkit.rul import HealthIndicator, LinearDegradationModel, RULPipeline


def _units(n: int, seed: int, cut: bool) -> pd.DataFrame:
    """Units degrading over 70-120 cycles (cut before failure when ``cut``)."""
    rng = np.random.default_rng(seed)
    rows = []
    for u in range(n):
        life = int(rng.integers(70, 120))
        t = np.arange(1, life + 1)
        stop = life - int(rng.integers(5, 50)) if cut else life
        frac = t / life
        s1 = frac**2 + rng.normal(0, 0.03, life)
        s2 = 1 - frac**3 + rng.normal(0, 0.03, life)
        rows.append(
            pd.DataFrame({"unit": u + 1, "cycle": t, "s1": s1, "s2": s2}).iloc[:stop]
        )
    return pd.concat(rows, ignore_index=True)


@pytest.fixture
def trained(tmp_path):
    """A saved pipeline and a history file of 8 cut test units."""
    train, test = _units(12, 2, cut=False), _units(8, 3, cut=True)
    pipe = RULPipeline(HealthIndicator(["s1", "s2"]), LinearDegradationModel())
    model = save_model(pipe.fit(train), tmp_path / "model.pdmkit")
    history = test
    history.to_csv(tmp_path / "history.csv", index=False)
    return model, tmp_path / "history.csv", history


def test_trained_answers_are_written_to_out(trained, tmp_path, capsys):
    model, history_path, history = trained
    out = tmp_path / "answers"
    copy = tmp_path / "copy.json"
    args = ["rul", "--trained", str(model), "--history", str(history_path)]
    assert main([*args, "--out", str(out), "--json", str(copy)]) == 0
    assert "wrote" in capsys.readouterr().err
    names = {p.name for p in out.iterdir()} - {".pdmkit"}
    assert names == set(OUTPUTS["rul-trained"])
    assert names == {"predictions.csv", "summary.json", "report.html"}
    written = pd.read_csv(out / "predictions.csv")
    # the same model, loaded and asked in this process
    expected = load_model(model).predict(history).to_pandas()
    assert written["unit"].tolist() == expected["unit"].tolist()
    np.testing.assert_allclose(written["cycle"], expected["time"])
    for key in ("rul", "lower", "upper"):
        np.testing.assert_allclose(written[key], expected[key], rtol=1e-12)
    assert (written["level"] == 0.9).all()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_units"] == 8 == len(summary["units"])
    assert summary["model_sha256"] == hashlib.sha256(model.read_bytes()).hexdigest()
    assert [u["rul"] for u in summary["units"]] == pytest.approx(expected["rul"].tolist())
    manifest = json.loads((out / ".pdmkit" / "run.json").read_text())
    assert manifest["command"] == "rul-trained"
    assert summary["run_id"] == manifest["run_id"]
    html = (out / "report.html").read_text()
    assert f'content="{manifest["run_id"]}"' in html
    assert copy.read_bytes() == (out / "summary.json").read_bytes()


def test_trained_without_out_writes_no_folder(trained, tmp_path, monkeypatch, capsys):
    model, history_path, _ = trained
    monkeypatch.chdir(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(["rul", "--trained", str(model), "--history", str(history_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no results/rul
    assert capsys.readouterr().out.count("RUL") == 8  # one line per unit, as before


def test_trained_out_must_not_overwrite_the_history(trained, tmp_path, capsys):
    model, history_path, _ = trained
    (tmp_path / "answers").mkdir()
    target = tmp_path / "answers" / "predictions.csv"
    target.write_bytes(history_path.read_bytes())
    args = ["rul", "--trained", str(model), "--history", str(target)]
    assert main([*args, "--out", str(target.parent)]) == 2
    assert "would overwrite the input" in capsys.readouterr().err
    assert target.read_bytes() == history_path.read_bytes()


# --------------------------------------------------------------------------- --test-rul
def test_true_rul_file_goes_line_by_line_to_the_units_in_order(tmp_path):
    test = pd.DataFrame({"unit": [1, 1, 2, 3, 3, 3], "cycle": [1, 2, 1, 1, 2, 3]})
    (tmp_path / "rul.txt").write_text("7\n0\n42\n")  # no header, as NASA ships it
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a bare column of numbers is not warned about
        merged = with_true_rul(test, tmp_path / "rul.txt")
    assert merged["rul_true_final"].tolist() == [7, 7, 0, 42, 42, 42]
    # two columns, unit and RUL: by unit id, in any order
    pd.DataFrame({"unit": [3, 1, 2], "RUL": [5, 6, 7]}).to_csv(
        tmp_path / "m.csv", index=False
    )
    by_id = with_true_rul(test, tmp_path / "m.csv")
    assert by_id["rul_true_final"].tolist() == [6, 6, 7, 5, 5, 5]


def test_true_rul_mistakes_are_one_line_errors(tmp_path):
    test = pd.DataFrame({"unit": [2, 1], "cycle": [1, 1]})
    path = tmp_path / "rul.csv"
    path.write_text("RUL\n5\n6\n")
    with pytest.raises(DataError, match="not ascending"):
        with_true_rul(test, path)
    path.write_text("RUL\n5\n")
    with pytest.raises(DataError, match=r"gives 1 true RULs for 2 test units"):
        with_true_rul(test.sort_values("unit"), path)
    path.write_text("RUL\n5\n-1\n")
    with pytest.raises(DataError, match="expected a number >= 0"):
        with_true_rul(test.sort_values("unit"), path)
    with pytest.raises(DataError, match="its own rul_true_final"):
        with_true_rul(test.assign(rul_true_final=1), path)


def test_test_rul_needs_test(tmp_path, capsys):
    code = main(["rul", "--train", "t.csv", "--test-rul", "r.txt", "--out", str(tmp_path)])
    assert code == 2 and "--test-rul FILE gives the true RULs" in capsys.readouterr().err


@pytest.mark.real_data
def test_cmapss_test_layout_scored_against_nasas_rul_file(require_data, tmp_path):
    folder = require_data("cmapss_fd001")
    out = tmp_path / "fd001"
    args = ["rul", "--train", str(folder / "train_FD001.txt")]
    args += ["--test", str(folder / "test_FD001.txt")]
    args += ["--test-rul", str(folder / "RUL_FD001.txt")]
    args += ["--unit", "unit_number", "--time", "time", "--time-unit", "cycles"]
    args += ["--model", "survival", "--out", str(out)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(args) == 0
    summary = json.loads((out / "summary.json").read_text())
    predictions = pd.read_parquet(out / "predictions.parquet")
    # independently: NASA's file, one RUL per line for units 1..100 (a header line here)
    true = pd.read_csv(folder / "RUL_FD001.txt", sep=r"\s+", skiprows=1, header=None)[0]
    true.index = np.arange(1, len(true) + 1)
    assert len(predictions) == 100 == summary["n_units"] and summary["rul_cap"] is None
    d = predictions.set_index("unit")["rul"] - true.reindex(predictions["unit"]).values
    assert summary["rmse"] == pytest.approx(math.sqrt((d**2).mean()), rel=1e-12)
    phm08 = sum(math.exp(-x / 13) - 1 if x < 0 else math.exp(x / 10) - 1 for x in d)
    assert summary["phm08_score"] == pytest.approx(phm08, rel=1e-9)
    assert summary["n_test_units"] == 100 and summary["n_train_units"] == 100


def test_trained_out_must_not_replace_the_training_runs_files(trained, capsys):
    model, history_path, _ = trained
    args = ["rul", "--trained", str(model), "--history", str(history_path)]
    assert main([*args, "--out", str(model.parent)]) == 2
    assert "is the folder of the trained model" in capsys.readouterr().err
    assert not (model.parent / "predictions.csv").exists()
