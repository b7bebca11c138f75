"""Tank effects for real recordings: a level-dependent cross-section, a clipped sensor
told from a tank's rim, companions grown with a lower bar, and the Cascaded Tanks
benchmark (issue 13: overflow on the upper tank and the 10 V ceiling named, validation
RMSE <= 0.30 V)."""

from __future__ import annotations

import math
import types
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pdmkit.models._xp import get_namespace
from pdmkit.models.mismatch._candidates import (
    CANDIDATES,
    Effect,
    _dummy_scales,
    attach_candidates,
)
from pdmkit.models.mismatch._locate import clipped_outputs
from pdmkit.models.mismatch._select import _adds_companion
from pdmkit.models.ode import showcase_model

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "cascaded_tanks"


def test_an_exact_ceiling_is_a_clip_a_noisy_rim_and_a_coarse_quantiser_are_not():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 30, 900)
    level = 5 + 4 * np.sin(t)
    noise = 0.01 * rng.normal(size=t.size)
    clipped = np.minimum(level + noise, 8.5)  # the sensor clips what it reads
    rim = np.minimum(level, 8.5) + noise  # the level stops at a rim; the noise stays
    coarse = np.round(level + noise, 1)  # a 0.1 quantiser repeats values everywhere
    assert clipped_outputs({"a": clipped, "b": rim, "c": coarse}) == ["a"]
    floor = np.maximum(level + noise, 1.5)  # a floor counts as well
    assert clipped_outputs({"d": floor, "flat": np.ones(50)}) == ["d"]


def test_no_overflow_is_attached_to_the_state_of_a_clipped_output():
    tanks = showcase_model("cascaded_tanks")
    sc = _dummy_scales(tanks)
    keys = {e.key for e in attach_candidates(tanks, sc)}
    assert {"overflow@h2", "overflow@h1->h2", "cross_section@h2"} <= keys
    keys = {e.key for e in attach_candidates(tanks, sc, clipped=["h2"])}
    assert "overflow@h2" not in keys and "overflow@h2->h1" not in keys
    assert {"overflow@h1->h2", "sensor_saturation@h2", "cross_section@h2"} <= keys
    # a vessel's shape is about levels, not pressures
    piston = showcase_model("pneumatic_piston")
    ids = {e.id for e in attach_candidates(piston, _dummy_scales(piston))}
    assert "leak" in ids and "cross_section" not in ids


def test_cross_section_scales_the_net_flow_by_the_area_at_the_level():
    cand = CANDIDATES["cross_section", "level"]
    eff = Effect(cand, "h2", None, {"mid": 5.0, "lo": 3.0, "hi": 10.0})
    xp = get_namespace(np.zeros(1))
    x = {"h2": np.array([5.0, 7.0, 3.0])}
    th = {"c": np.array([-0.1, -0.1, -0.1])}
    dx = cand.derivs(xp, eff, th, 0.0, x, {}, {"h2": np.ones(3)})
    # narrower above the median level (area exp(-0.2)): the level moves faster there
    assert dx["h2"] == pytest.approx(np.exp([0.0, 0.2, -0.2]))
    neutral = {"c": np.zeros(3)}
    assert cand.derivs(xp, eff, neutral, 0.0, x, {}, {"h2": np.ones(3)})["h2"] == (
        pytest.approx(np.ones(3))
    )
    text = cand.explain(eff, {"c": -0.1})
    assert "cross-section" in text and f"×{math.exp(-0.5):.3g} at 10" in text


def test_a_companion_added_to_a_structure_is_recognised():
    tanks = showcase_model("cascaded_tanks")
    by_key = {e.key: e for e in attach_candidates(tanks, _dummy_scales(tanks))}
    ovf, sat, dz = (
        by_key["overflow@h1->h2"],
        by_key["sensor_saturation@h2"],
        by_key["dead_zone@u"],
    )

    def s(*effects):
        return types.SimpleNamespace(effects=effects)

    assert _adds_companion(s(dz, ovf, sat), s(dz, ovf))  # sensor clip beside an overflow
    assert not _adds_companion(s(ovf, dz), s(ovf))  # a dead zone is no companion
    assert not _adds_companion(s(ovf), s(ovf))


@pytest.mark.slow
@pytest.mark.real_data
def test_cascaded_tanks_example_names_overflow_and_the_sensor_ceiling(require_data):
    require_data("cascaded_tanks")
    from scipy.io import loadmat

    from pdmkit.models import discover_mismatch, load_model_file

    mat = loadmat(require_data("cascaded_tanks") / "dataBenchmark.mat")
    ts = float(np.ravel(mat["Ts"])[0])
    col = lambda k: np.ravel(mat[k]).astype(float)  # noqa: E731
    t = np.arange(col("uEst").size) * ts
    est = pd.DataFrame({"time": t, "u": col("uEst"), "h2": col("yEst")})
    val = pd.DataFrame({"time": t, "u": col("uVal"), "h2": col("yVal")})
    model = load_model_file(EXAMPLE / "model.py", model_timeout=None)
    res = discover_mismatch(model, est, val)
    v = res.verdict
    named = {(v["effect"], v["target"])} | {
        (a["effect"], a["target"]) for a in v.get("also", [])
    }
    assert {("overflow", "h1"), ("sensor_saturation", "h2")} <= named, named
    assert ("overflow", "h2") not in named  # the exact 10 V plateau is the sensor's
    assert res.fit["rmse_augmented"] <= 0.30
    sat = next(a for a in [v, *v.get("also", [])] if a["effect"] == "sensor_saturation")
    assert 9.8 <= sat["params"]["high"] <= 10.05
    # the lower limit is never reached by the fitted model: not reported as a finding
    assert sat["params"]["low"] is None and "(never reached)" in sat["physics"]
    # the effects by weight: the validation RMSE with each removed (the rest refitted),
    # the weightiest first and leading the headline; none is free (each costs)
    weights = [w["rmse_without"] for w in v["weights"]]
    assert weights == sorted(weights, reverse=True)
    assert min(weights) > res.fit["rmse_augmented"]
    lead = v["weights"][0]
    assert v["headline"].startswith(f"{lead['effect']} on {lead['target']}")
    assert (v["effect"], v["target"]) == (lead["effect"], lead["target"])
    # the overflow is among the effects that explain most
    top = [w for w in v["weights"] if w["rmse_without"] >= 0.98 * weights[0]]
    assert ("overflow", "h1") in {(w["effect"], w["target"]) for w in top}, v["weights"]
    assert ("not white" in v["headline"]) == (not v["confidence"]["white_after"])
    # the overflow is active: the fitted upper tank reaches its cap
    from pdmkit.models.ode._simulate import simulate_ode

    vals, effs = res.augmented_values, res.augmented_effects
    sim = simulate_ode(
        model,
        t,
        {"u": col("uEst")},
        params={k: vals[f"p:{k}"] for k in model.params},
        x0={s: vals[f"x0:{s}"] for s in model.states},
        effects=effs,
        effect_params={q: vals[q] for e in effs for q in e.qualified()},
    )
    cap = next(a for a in [v, *v.get("also", [])] if a["effect"] == "overflow")
    assert sim.states["h1"][0].max() >= 0.97 * cap["params"]["cap"]
    # literature: Torricelli without overflow about 0.64 V validation RMSE
    assert 0.6 < res.fit["rmse_nominal"] < 0.7
    # the two located windows with most residual energy hold the episodes where the
    # lower-tank sensor reads its 10 V ceiling (the rig's overflow episodes), and the
    # fitted upper tank sits at its cap there
    y, h1 = col("yEst"), sim.states["h1"][0]
    for w in res.located[:2]:
        inside = (t >= w["start"]) & (t < w["end"])
        assert y[inside].max() >= 9.9
        assert h1[inside].max() >= 0.97 * cap["params"]["cap"]
