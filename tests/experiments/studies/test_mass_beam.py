"""``pdmkit study mass-beam`` (Khatkhate et al. 2007): the study end to end, quick."""

import json

import numpy as np
import pytest

from pdmkit.experiments.studies import run_study

MEASURES = {
    "SDF, uniform partition",
    "SDF, maximum-entropy partition",
    "SDF, SFNN partition",
    "SDF, wavelet space",
    "PCA",
    "RBF network",
    "MLP",
}


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("mass_beam")
    summary = run_study("mass-beam", out, quick=True, seed=0)
    return out, summary


def test_outputs_and_seed_numbers_beside_pdmkit(study):
    out, summary = study
    assert json.loads((out / "summary.json").read_text())["study"] == "mass-beam"
    html = (out / "report.html").read_text()
    # the paper's numbers (section 3, 5, 6) appear beside pdmkit's
    for text in ("73.3", "28.9", "87.8", "within 16 min", "more than 24 min", "SFNN"):
        assert text in html, text
    seed = summary["seed_numbers"]
    assert seed["resonances_rad_s"]["system 1 (m3)"] == 73.3


def test_resonances_against_the_seed(study):
    """System 1 from table 1 alone within 0.5 % of 73.3 rad/s (section 3.1.1)."""
    _, summary = study
    rows = {r["resonance"]: r for r in summary["resonances"]}
    assert rows["system 1 (m3)"]["lumped, effective masses"] == pytest.approx(
        73.3, rel=0.005
    )
    fe = rows["system 2, upper (m1)"]["beam mass distributed (FE)"]
    assert fe == pytest.approx(87.8, rel=0.02)


def test_fatigue_and_detection_tables(study):
    _, summary = study
    files = summary["fatigue"]["files"]
    loss = np.array([f["stiffness_loss"] for f in files])
    assert len(files) == 18 and np.all(np.diff(loss) > 0)
    for key in ("raw", "unit_rms"):
        rows = summary["detection"][key]
        assert {r["measure"] for r in rows} == MEASURES
        for r in rows:
            assert 0 <= r["false alarms on new nominal repeats"] <= 1
            t = r["detected at (min)"]
            assert t is None or 2 <= t <= 36
    # as recorded, the anomaly (a growing amplitude) is seen by every measure
    raw = {r["measure"]: r for r in summary["detection"]["raw"]}
    assert all(r["detected at (min)"] is not None for r in raw.values())
    assert all(r["Spearman with stiffness loss"] > 0.8 for r in raw.values())
    sf = {r["partition"]: r["SFNN fraction"] for r in summary["sfnn"]}
    assert sf["SFNN"] <= min(sf["uniform"], sf["maximum entropy"])


@pytest.mark.real_data
def test_real_run_to_failure_is_scored(study, require_data):
    require_data("femto_pronostia_bearing1_1")
    _, summary = study
    real = summary["real_data"]["measures"]
    assert set(real) == MEASURES
    # at the end of the bearing's life every measure is above its early-life level
    assert all(v["last_over_alarm"] > 1 for v in real.values())
