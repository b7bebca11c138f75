"""``pdmkit study unstable-closed-loop``: the S-Mobile paper's method, quick run.

References: the seed's identified ``theta_x = 20.31`` (sec. 5, "confirmed by the design
data", the rig's design value here); the exact linearisation's unstable pole and its
closed form; the rig's drive lag; the F-16 and EMPS recordings (real data).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit.experiments.studies import run_study
from pdmkit.experiments.studies._closed_loop import SEED_THETA_X, seed_error


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("closed_loop")
    return run_study("unstable-closed-loop", out, quick=True), out


@pytest.mark.slow
def test_truth_is_the_exact_linearisation(quick):
    s, _ = quick
    t = s["truth"]
    assert t["unstable_pole_frictionless"] == pytest.approx(t["closed_form_frictionless"])
    assert 0 < t["unstable_pole"] < t["unstable_pole_frictionless"]  # friction slows it
    assert s["actuator"]["T_m_identified"] == pytest.approx(
        s["actuator"]["T_m_true"], rel=0.02
    )


@pytest.mark.slow
def test_the_seeds_approach_recovers_theta_x_within_5_points(quick):
    s, _ = quick
    fits = pd.DataFrame(s["seed_approach"])
    small = fits[fits["amplitude_deg"] == fits["amplitude_deg"].min()]
    assert (small["theta_x"] / SEED_THETA_X - 1).abs().max() < 0.05
    # the unstable pole of the fitted physical model, against the truth
    assert (small["unstable_pole"] / s["truth"]["unstable_pole"] - 1).abs().max() < 0.05


@pytest.mark.slow
def test_closed_loop_methods_against_the_truth(quick):
    s, _ = quick
    # on the linear plant (no Coulomb friction, no torque limit) indirect and joint
    # identification are consistent: the unstable pole within 2 %
    lin = pd.DataFrame(s["linear_control"]).set_index("method")
    assert lin.loc["indirect", "error_percent"] == pytest.approx(0, abs=2)
    assert lin.loc["joint", "error_percent"] == pytest.approx(0, abs=2)
    # with the friction the FRF stays close in the band, the pole moves
    methods = pd.DataFrame(s["methods"])
    small = methods[(methods["amplitude_deg"] == methods["amplitude_deg"].min())]
    best = small[small["method"] != "direct"]
    assert (best["frf_error_db"] < 1.0).all()


@pytest.mark.slow
def test_amplitude_dependent_frfs_and_coherence(quick):
    s, out = quick
    frf = s["frf"]
    assert frf["amplitude_dependent"] is True  # friction and the torque limit
    assert min(frf["coherence_edge_hz"]) > 5.0  # seed: coherence lost from ~20 Hz
    html = (out / "report.html").read_text()
    assert "20.31" in html and "coherence" in html


def test_seed_error_is_zero_for_a_perfect_model_and_weights_by_coherence():
    H = np.exp(1j * np.linspace(0, 1, 5))
    assert seed_error(H, H, np.ones(5))["eps"] == 0.0
    e = seed_error(2 * H, H, np.ones(5))
    assert e["eps_mag"] == pytest.approx((20 * np.log10(2)) ** 2, rel=1e-12)
    assert seed_error(2 * H, H, np.zeros(5))["eps"] == 0.0


@pytest.mark.slow
@pytest.mark.real_data
def test_real_data_checks(quick, require_data):
    require_data("f16_gvt")
    require_data("emps")
    s, _ = quick
    f16 = s["real_data"]["f16"]
    # the F-16's joint mode near 7.3 Hz softens at the higher force level
    assert f16["nonlinear"] is True
    assert f16["peak_near_7hz"][1] < f16["peak_near_7hz"][0]
    emps = s["real_data"]["emps"]["estimates"]["indirect"]
    assert abs(emps["M_error_percent"]) < 5 and abs(emps["Fv_error_percent"]) < 10
