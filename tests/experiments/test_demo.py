"""`pdmkit demo`: the whole workflow on the twin writes a complete summary and report."""

from __future__ import annotations

import json

import pytest

from pdmkit.experiments._cli import main


@pytest.mark.slow
def test_demo_writes_summary_and_report(tmp_path):
    out = tmp_path / "demo"
    assert (
        main(
            [
                "demo",
                "--out",
                str(out),
                "--members",
                "64",
                "--seed",
                "2",
                "--recording-s",
                "2.5",
            ]
        )
        == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    # 16 fault codes (healthy, five single faults, ten pairs), four members each
    assert summary["members"] == 64
    assert len(summary["labels"]) == 16
    assert "cycle" in summary["feature_groups"]
    assert {row["sensor"] for row in summary["sensors"]} == {
        "Acc",
        "Encoder",
        "Flow",
        "Mics",
        "Pressure",
        "Proximity",
        "Strain",
        "Temperature",
    }
    for model in ("knn", "bagged_trees"):
        result = summary["classification"][model]
        assert 0.0 <= result["accuracy"] <= 1.0 and len(result["features"]) == 5
    residuals = summary["residuals"]
    for key in ("accuracy_residual", "accuracy_signal", "accuracy_residual_signal"):
        assert 0.0 <= residuals[key] <= 1.0
        assert 0.0 <= residuals["per_point_standardised"][key] <= 1.0
    best = summary["best_sensor"]
    assert best["heldout_accuracy"] == max(
        row["heldout_accuracy"] for row in summary["sensors"]
    )
    rul = summary["rul"]
    assert rul["model"] == "linear-degradation"
    assert (rul["n_train_units"], rul["n_units"]) == (8, 4)
    # every test unit is scored at each cycle of the last half of its life (lives of
    # roughly 16-40 cycles)
    assert rul["n_predictions"] >= 4 * 5
    assert 0.0 <= rul["mae"] <= rul["rmse"]
    for value in rul["within_10pct"].values():
        assert 0.0 <= value <= 1.0
    # over the last half of life the RUL is found to within a quarter of the shortest
    # typical life (16 cycles) on average
    assert rul["mae"] < 4.0
    # the concealed chamber leak is named, and the named leak fits the recordings better
    (piston, *real) = summary["mismatch"]
    assert (piston["effect"], piston["target"], piston["right"]) == ("leak", "pa", True)
    assert piston["fit"]["rmse_augmented"] < 0.5 * piston["fit"]["rmse_nominal"]
    assert real == []  # quick checks leave the real recordings out
    assert (out / "rul" / "report.html").exists()
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 8
    assert "Remaining useful life" in html
    assert "Mismatch discovery" in html
    assert (out / "features.parquet").stat().st_size > 0
