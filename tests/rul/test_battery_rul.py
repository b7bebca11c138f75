"""RUL on real degradation data: the NASA Li-ion cells (skipped without the data).

The loader against the CSV files read independently; the leave-one-cell-out workflow
of ``run_rul("nasa-battery")``: the noisy Wiener model beats the regression line, a
trained model answers a cell's RUL, models that do not apply are named.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pdmkit import data_dir
from pdmkit.ensembles import load_nasa_battery
from pdmkit.errors import DataError
from pdmkit.experiments import predict_rul, run_rul

pytestmark = pytest.mark.real_data


def test_loader_cuts_each_cell_at_its_end_of_life(require_data):
    folder = require_data("nasa_battery")
    cells = load_nasa_battery()
    for cell, part in cells.groupby("unit"):
        raw = pd.read_csv(folder / f"{cell}_cycle_summary.csv")
        below = np.flatnonzero(raw["capacity"].to_numpy() < 1.4)
        end = below[0] + 1 if below.size else len(raw)
        assert len(part) == end
        np.testing.assert_array_equal(part["capacity"], raw["capacity"][:end])
        assert part["failed"].tolist() == [False] * (end - 1) + [bool(below.size)]
    ends = cells.groupby("unit")["cycle"].max().to_dict()
    assert ends == {"B0005": 125, "B0006": 109, "B0007": 168, "B0018": 97}
    whole = load_nasa_battery(["B0007"], eol_capacity=None)
    assert len(whole) == 168 and "failed" not in whole
    with pytest.raises(DataError, match="B0099"):
        load_nasa_battery(["B0099"])


@pytest.fixture(scope="module")
def battery_runs(tmp_path_factory):
    if not (data_dir("nasa_battery") / "B0005_cycle_summary.csv").is_file():
        pytest.skip(f"real dataset 'nasa_battery' not found in {data_dir('nasa_battery')}")
    out = tmp_path_factory.mktemp("battery")
    runs = {
        model: run_rul("nasa-battery", model, out / model)
        for model in ("linear-degradation", "wiener-noisy")
    }
    return out, runs


def test_noisy_wiener_beats_the_regression_line_on_the_cells(battery_runs):
    out, runs = battery_runs
    noisy, line = runs["wiener-noisy"], runs["linear-degradation"]
    for summary in runs.values():
        assert {"model", "rmse", "mae", "phm08_score", "n_units", "coverage"} <= set(
            summary
        )
        assert summary["n_units"] == 3 and summary["censored_cells"] == ["B0007"]
    # capacity regenerates between discharges: the line's iid noise misreads it
    assert noisy["rmse"] < 0.7 * line["rmse"]
    assert noisy["coverage"] > 0.8 > line["coverage"]
    on_disk = json.loads((out / "wiener-noisy" / "summary.json").read_text())
    assert on_disk["rmse"] == pytest.approx(noisy["rmse"])


def test_trained_model_answers_a_cell_history(battery_runs, tmp_path):
    out, _ = battery_runs
    history = load_nasa_battery(["B0006"]).query("cycle <= 60").drop(columns="unit")
    history.to_csv(tmp_path / "B0006.csv", index=False)
    (row,) = predict_rul(out / "wiener-noisy" / "model.pdmkit", tmp_path / "B0006.csv")[
        "units"
    ]
    assert row["unit"] == "B0006" and row["time"] == 60
    assert row["lower"] <= row["rul"] <= row["upper"] and np.isfinite(row["rul"])


def test_models_that_do_not_apply_are_named(require_data, tmp_path):
    require_data("nasa_battery")
    with pytest.raises(DataError, match="does not apply to 'nasa-battery'"):
        run_rul("nasa-battery", "pairwise", tmp_path)
    with pytest.raises(DataError, match="no dataset options"):
        run_rul("nasa-battery", "wiener", tmp_path, dataset_options={"n_test": 2})
