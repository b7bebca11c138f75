"""``pdmkit study motor-fractional`` : the fractional-calculus study end to end, quick."""

import json

import numpy as np
import pytest

from pdmkit.experiments.studies import run_study


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("motor")
    summary = run_study("motor-fractional", out, quick=True, seed=0)
    return out, summary


def test_outputs_and_seed_tables_beside_pdmkit(study):
    out, summary = study
    assert json.loads((out / "summary.json").read_text())["study"] == "motor-fractional"
    html = (out / "report.html").read_text()
    for text in ("1.84 / 3.23", "91.7", "Table 1", "table 2"):
        assert text in html, text
    seed = summary["seed_numbers"]
    assert np.trace(seed["table2"]) == 220 and np.sum(seed["table2"]) == 240


def test_fractional_beats_integer_in_every_case(study):
    """Table 1: the FOM holds the IOM (alpha = 2, beta = 1), so with a working simplex
    its error is below the IOM's in every case, on the tuning and the test records."""
    _, summary = study
    for row in summary["main"]["table1"]:
        assert row["train FOM"] < row["train IOM"]
        assert row["test FOM"] < row["test IOM"]
    assert summary["main"]["ratio_test_mean"] < 0.7


def test_knn_protocol_of_table_2(study):
    _, summary = study
    cm = np.array(summary["main"]["confusion_k3"])
    assert cm.shape == (4, 4) and cm.sum() == 240 and np.all(cm.sum(axis=1) == 60)
    assert summary["main"]["accuracy_k3"] == pytest.approx(np.trace(cm) / 240)
    assert summary["main"]["accuracy_k3"] >= 0.9
    ks = [r["k"] for r in summary["main"]["per_k"]]
    assert 3 in ks


@pytest.mark.real_data
def test_silverbox_section(study, require_data):
    require_data("silverbox")
    _, summary = study
    real = summary["real_data"]
    assert real["fom"]["alpha"] == pytest.approx(2.0, abs=0.05)
    assert real["ratio"] == pytest.approx(1.0, abs=0.1)
