"""`pdmkit demo`: the whole workflow on the twin writes a complete summary and report."""

from __future__ import annotations

import json

import pytest

from pdmkit._outputs import OUTPUTS


@pytest.mark.slow
def test_demo_writes_summary_and_report(demo_run):
    # the run (tests/experiments/conftest.py) found the output folder holding the
    # user's files and a stale run's: the demo replaces its own files and leaves the
    # user's byte for byte (the demo's case of tests/security/test_output_folders.py)
    tmp_path, out = demo_run.tmp, demo_run.out
    assert demo_run.code == 0
    assert (out / "notes.txt").read_text() == "mine\n"
    assert (out / "rul" / "mine.csv").read_text() == "a,b\n1,2\n"
    manifest = json.loads((out / ".pdmkit" / "run.json").read_text())
    assert set(manifest["files"]) == set(OUTPUTS["demo"])
    for name in OUTPUTS["demo"]:
        assert (out / name).read_bytes() != b"stale\n", name
    assert (tmp_path / "copy.json").read_bytes() == (out / "summary.json").read_bytes()
    summary = json.loads((out / "summary.json").read_text())
    # the seed's 20 labels (the author's faultCode2Label), every one simulated
    assert summary["members"] == 80
    assert len(summary["labels"]) == 20
    assert "cycle" in summary["feature_groups"]
    # each seed recipe beside the seed's published number (Voronin, tables 7.2, 9.1)
    published = {
        "flow_knn": 97.52,
        "flow_bagged_trees": 99.45,
        "flow_pca_bagged_trees": 95.18,
        "residual_classification": 99.49,
    }
    rows = {row["recipe"]: row for row in summary["seed_comparison"]}
    for recipe, number in published.items():
        assert rows[recipe]["seed"] == number
        assert 0.0 <= rows[recipe]["pdmkit"] <= 100.0
    seed_sensors = [row["sensor"] for row in summary["seed_sensors"]["rows"]]
    assert len(seed_sensors) == 7 and seed_sensors[0] == "Flow"  # the seed's order
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
    forest = summary["classification"]["operating_point_forest"]
    assert 0.0 <= forest["accuracy"] <= 1.0 and len(forest["features"]) == 5
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
    assert html.count("data:image/png;base64,") >= 6
    assert "Remaining useful life" in html
    assert "Mismatch discovery" in html
    # the summary box heads the report and links to the sections
    assert html.index('class="summary"') < html.index("<h2 id=")
    assert html.count('<a href="#') >= 5
    assert (out / "features.parquet").stat().st_size > 0
