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
                "36",
                "--seed",
                "2",
                "--recording-s",
                "2.5",
            ]
        )
        == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["members"] == 36
    assert len(summary["labels"]) == 6
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
    assert 0.0 <= summary["residuals"]["accuracy_residual"] <= 1.0
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 6
    assert (out / "features.parquet").stat().st_size > 0
