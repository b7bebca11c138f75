"""``pdmkit rul`` on a newcomer's files as they come (issue 15): a wide table (a time
column, one column per unit, as the IMS bearing files come) read with ``--wide NAME``;
a header-less history (the raw C-MAPSS test files) answered by a model trained on a
headed table of the same width; histories far from the training rows warned about in
``--trained`` too."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError
from pdmkit.experiments._cli import main
from pdmkit.experiments._cli_rul import _long_from_wide


def _wide(n_units: int = 12, seed: int = 0) -> pd.DataFrame:
    """Bearings that wear out one after the other: a timestamp every 10 min, one column
    per bearing, the reading growing until the bearing fails (then no more rows)."""
    rng = np.random.default_rng(seed)
    n = 400
    stamps = pd.date_range("2004-02-12 10:32:39", periods=n, freq="10min")
    table = {"": stamps.strftime("%Y-%m-%d %H:%M:%S")}
    for u in range(n_units):
        life = int(rng.integers(200, n))
        x = 0.05 + 0.4 * (np.arange(n) / life) ** 3 + rng.normal(0, 0.003, n)
        x[life:] = np.nan  # the bearing has failed: nothing recorded after
        table[f"Bearing {u + 1}"] = x
    return pd.DataFrame(table)


def test_a_wide_table_becomes_units_from_its_columns() -> None:
    wide = _wide(3)
    long = _long_from_wide(wide, "w.csv", None, "vibration", None)
    assert sorted(long["unit"].unique()) == ["Bearing 1", "Bearing 2", "Bearing 3"]
    assert list(long.columns) == ["time", "unit", "vibration"]
    # each unit's rows are its column, in time order, without the rows after failure
    b2 = long[long["unit"] == "Bearing 2"]
    expected = wide["Bearing 2"].dropna().to_numpy()
    np.testing.assert_array_equal(b2["vibration"].to_numpy(), expected)
    assert b2["time"].is_monotonic_increasing


def test_rul_trains_on_a_wide_file_end_to_end(tmp_path) -> None:
    path = tmp_path / "ims_like.csv"
    _wide(12).to_csv(path, index=False)
    out = tmp_path / "out"
    args = ["rul", "--train", str(path), "--wide", "vibration"]
    code = main([*args, "--model", "linear-degradation", "--out", str(out)])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["time_unit"] == "s"  # timestamps became seconds
    assert summary["n_test_units"] >= 1


@pytest.mark.parametrize(
    ("time", "unit", "name", "message"),
    [
        ("when", None, "vibration", "--time 'when' is not a column"),
        (None, "bearing", "vibration", "drop --unit"),
        (None, None, "unit", "clashes"),
    ],
)
def test_wide_mistakes_are_one_line_errors(time, unit, name, message) -> None:
    with pytest.raises(DataError, match=message):
        _long_from_wide(_wide(2), "w.csv", time, name, unit)


def _engines(n: int, seed: int, shift: float = 0.0) -> pd.DataFrame:
    """Engines run to failure, text with a header: unit_number, time, s1, s2."""
    rng = np.random.default_rng(seed)
    rows = []
    for u in range(n):
        life = int(rng.integers(80, 140))
        t = np.arange(1, life + 1)
        s1 = 10 + 3 * (t / life) ** 2 + rng.normal(0, 0.05, t.size) + shift
        s2 = 5 - 2 * (t / life) ** 2 + rng.normal(0, 0.05, t.size) - shift
        rows.append(pd.DataFrame({"unit_number": u + 1, "time": t, "s1": s1, "s2": s2}))
    return pd.concat(rows, ignore_index=True)


def _trained(tmp_path):
    train = tmp_path / "train.txt"
    _engines(16, 1).to_csv(train, sep=" ", index=False)
    out = tmp_path / "model"
    args = ["rul", "--train", str(train), "--unit", "unit_number", "--time", "time"]
    assert main([*args, "--model", "linear-degradation", "--out", str(out)]) == 0
    return out / "model.pdmkit"


def test_a_headerless_history_takes_the_training_tables_names(tmp_path) -> None:
    model = _trained(tmp_path)
    history = tmp_path / "history.txt"
    part = _engines(3, 2)
    part[part["time"] <= 60].to_csv(history, sep=" ", index=False, header=False)
    out = tmp_path / "answer"
    with pytest.warns(UserWarning, match="no header; its 4 columns are read as the model"):
        code = main(["rul", "--trained", str(model), "--history", str(history),
                     "--json", str(out.with_suffix(".json"))])  # fmt: skip
    assert code == 0
    answer = json.loads(out.with_suffix(".json").read_text())
    assert [u["unit"] for u in answer["units"]] == [1, 2, 3]


def test_trained_histories_far_from_the_training_rows_are_warned(tmp_path) -> None:
    model = _trained(tmp_path)
    near, far = tmp_path / "near.txt", tmp_path / "far.txt"
    _engines(3, 3).query("time <= 60").to_csv(near, sep=" ", index=False)
    _engines(3, 4, shift=3.0).query("time <= 60").to_csv(far, sep=" ", index=False)
    results = {}
    for name, path in (("near", near), ("far", far)):
        target = tmp_path / f"{name}.json"
        args = ["rul", "--trained", str(model), "--history", str(path)]
        assert main([*args, "--unit", "unit_number", "--json", str(target)]) == 0
        results[name] = json.loads(target.read_text())
    assert not any("outside the training data" in w for w in results["near"]["warnings"])
    assert any("3 of 3 test units lie outside" in w for w in results["far"]["warnings"])
    assert all(u["ood_score"] > 1 for u in results["far"]["units"])
    assert all(u["ood_score"] < 1 for u in results["near"]["units"])
