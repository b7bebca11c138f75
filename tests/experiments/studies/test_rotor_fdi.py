"""``pdmkit study rotor-fdi``: the seed-000 FDI workflow end to end (quick run).

What is asserted comes from outside the workflow: the rig's faults are known by
construction (a run's truth), the seed's recommendations (AR order of 10 or more,
sec. 4.3.3; Table 15's filters; the 256-sample buffer) and the binary matrix's rule
that every fault has its own symptom vector (sec. 2.8.2).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from threadpoolctl import threadpool_limits

from pdmkit.experiments.studies import run_study
from pdmkit.experiments.studies._rotor_pipeline import (
    FORGETTING_FACTORS,
    ROTOR_MATRIX,
    SYMPTOMS,
    diagnose_record,
    reference_modes,
)
from pdmkit.models.diagnosis import DiagnosticMask, DiagnosticMatrix
from pdmkit.models.rigs import ROTOR_FAULTS, RotorRig


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("rotor")
    summary = run_study("rotor-fdi", out, quick=True)
    return summary, out


@pytest.mark.slow
def test_every_fault_isolated_and_no_false_isolation_at_every_forgetting_factor(quick):
    summary, _ = quick
    runs = pd.DataFrame(summary["runs"])
    assert set(runs["forgetting"]) == {FORGETTING_FACTORS[0], FORGETTING_FACTORS[-1]}
    # the truth of each run is the fault the rig switched on
    assert set(runs["fault"]) == {"normal", *ROTOR_FAULTS}
    wrong = runs[runs["verdict"] != runs["fault"]]
    assert wrong.empty, wrong[["forgetting", "fault", "verdict"]].to_string()
    assert summary["all_isolated"] and summary["no_false_isolation"]
    # detection comes after the onset, within the memory's reach (seconds)
    faults = runs[runs["fault"] != "normal"]
    assert (faults["isolation_delay_s"] >= 0).all() and (
        faults["isolation_delay_s"] < 10
    ).all()


@pytest.mark.slow
def test_order_selection_and_seed_settings(quick):
    summary, out = quick
    # seed sec. 4.3.3: "AR with order of 10 or higher is recommended"
    for per in summary["order_selection"].values():
        assert per["aic"] >= 10 and per["mdl"] >= 10
    assert summary["seed_buffer_samples"] == 256
    for rel in summary["channel_to_channel"]:
        assert rel["fit_percent"] > 0
    html = (out / "report.html").read_text()
    for text in ("AR(12)", "Table 15", "median 50", "256-sample", "Diagnostic matrix"):
        assert text.lower() in html.lower(), text
    assert json.loads((out / "summary.json").read_text())["study"] == "rotor-fdi"


def test_the_matrix_isolates_uniquely():
    matrix = DiagnosticMatrix(ROTOR_MATRIX, symptoms=list(SYMPTOMS))  # raises if not
    assert matrix.faults == list(ROTOR_FAULTS)
    assert matrix.diagnose(np.eye(len(SYMPTOMS))[0]).tolist() == ["unbalance"]


def test_reference_modes_come_from_the_rig_model():
    rig = RotorRig()
    freqs, bending = reference_modes(rig)
    modes = rig.modes()
    below = modes[modes["frequency_hz"] < 0.45 * 256]
    # close pairs (x and y of one mode) are merged; the bending mode is the least damped
    assert len(freqs) == 3 and freqs[0] == pytest.approx(below["frequency_hz"].iloc[0])
    assert freqs[bending] == pytest.approx(22.9, abs=0.2)


def test_a_verdict_needs_three_seconds():
    fs = 256.0
    n = 20 * 256
    cols = [q for q, _, _ in SYMPTOMS.values()]
    q = pd.DataFrame(np.zeros((n, len(cols))), columns=cols)
    q.iloc[5000:, 0] = 10.0  # the 1X quantity high for 0.47 s only: too short
    masks = {s: DiagnosticMask(upper=1.0).fit() for s in SYMPTOMS}
    matrix = DiagnosticMatrix(ROTOR_MATRIX, symptoms=list(SYMPTOMS))
    with threadpool_limits(1, user_api="blas"):
        _, labels, verdict = diagnose_record(q, masks, matrix, warmup=256, fs=fs)
    assert verdict == "normal" and (labels == "unbalance").sum() == n - 5000
    q.iloc[2000:, 0] = 10.0
    assert diagnose_record(q, masks, matrix, warmup=256, fs=fs)[2] == "unbalance"
