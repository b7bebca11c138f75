"""Mismatch discovery on concealed cases (known truth) and on the real Cascaded Tanks."""

from __future__ import annotations

import numpy as np
import pytest

from pdmkit.errors import ModelError
from pdmkit.models.mismatch import dm_test
from pdmkit.models.mismatch._cases import generate_concealed_case
from pdmkit.models.mismatch._discover import discover_mismatch
from pdmkit.models.ode import showcase_model
from pdmkit.models.ode._simulate import simulate_ode

# a competing set for each concealed case: the true effect and its look-alikes
FRICTION = [
    "coulomb_friction",
    "stribeck_friction",
    "viscous_friction",
    "cubic_stiffness",
    "dead_zone",
]
LEVEL = ["overflow", "leak", "saturation", "sensor_offset", "input_lag"]


def test_dm_test_level_and_power():
    """Under equal accuracy the one-sided DM p-value is ~U(0,1); a real gain is found."""
    rng = np.random.default_rng(3)
    p = [dm_test(rng.normal(size=400), rng.normal(size=400))[1] for _ in range(300)]
    assert np.mean(np.array(p) < 0.01) < 0.03
    e = rng.normal(size=400)
    assert dm_test(e * 1.3, e)[1] < 1e-6


def test_control_with_misset_parameter_gives_none():
    case = generate_concealed_case("none", 0.25, seed=11, n_samples=900)
    res = discover_mismatch(case.model, case.data, effects=FRICTION + LEVEL, pairs=False)
    assert res.verdict["effect"] == "none" and res.verdict["target"] is None
    # the mis-set free parameter is re-estimated to its true value
    free = case.model.free[0]
    assert res.fit["free_nominal"][free] == pytest.approx(case.true_params[free], rel=0.02)
    assert res.fit["rmse_augmented"] == res.fit["rmse_nominal"]


@pytest.mark.slow
def test_hidden_coulomb_friction_is_named_and_fitted():
    case = generate_concealed_case("coulomb_friction", 0.2, seed=5, n_samples=1200)
    res = discover_mismatch(case.model, case.data, effects=FRICTION, pairs=False)
    assert (res.verdict["effect"], res.verdict["target"]) == ("coulomb_friction", "v")
    assert res.fit["rmse_augmented"] < 0.5 * res.fit["rmse_nominal"]
    # the friction level (per unit mass; m = 1) within 15 % of the concealed one
    assert res.verdict["params"]["a"] == pytest.approx(case.params["a"], rel=0.15)
    assert "Coulomb" in res.verdict["physics"]
    # friction leaves its signature at low speed
    top = res.regions["region"].head(3).tolist()
    assert any(r.startswith("v") for r in top)


@pytest.mark.slow
def test_hidden_overflow_on_tanks():
    case = generate_concealed_case("overflow", 0.2, seed=3)
    res = discover_mismatch(case.model, case.data, effects=LEVEL, pairs=False)
    assert (res.verdict["effect"], res.verdict["target"]) == ("overflow", "h1")
    assert res.verdict["params"]["cap"] == pytest.approx(case.params["cap"], rel=0.03)
    assert res.fit["rmse_augmented"] < 0.5 * res.fit["rmse_nominal"]


@pytest.mark.slow
def test_hidden_dead_time_on_tanks():
    case = generate_concealed_case("dead_time", 0.2, seed=4, target="u", system="two_tanks")
    res = discover_mismatch(
        case.model, case.data, effects=["dead_time", "input_lag", "sensor_lag"], pairs=False
    )
    assert (res.verdict["effect"], res.verdict["target"]) == ("dead_time", "u")
    assert res.verdict["params"]["tau"] == pytest.approx(case.params["tau"], rel=0.1)


def test_pneumatic_showcase_settles_where_the_valve_and_spring_say():
    """Held command u: p_A -> p0 + (1+u)/2 (ps - p0), p_B mirrored, spring balances."""
    m = showcase_model("pneumatic_piston")
    p = m.params
    t = np.arange(2001) * 0.005
    for u in (-0.6, 0.2, 0.9):
        r = simulate_ode(m, t, {"u": np.full(t.size, u)}, n_sub=2)
        pa = p["p_ambient"] + 0.5 * (1 + u) * (p["p_supply"] - p["p_ambient"])
        pb = p["p_ambient"] + 0.5 * (1 - u) * (p["p_supply"] - p["p_ambient"])
        force = (
            pa * p["area_a"]
            - pb * p["area_b"]
            - p["p_ambient"] * (p["area_a"] - p["area_b"])
        )
        assert r.outputs["pa"][0, -1] == pytest.approx(pa, rel=1e-4)
        assert r.outputs["pb"][0, -1] == pytest.approx(pb, rel=1e-4)
        assert r.outputs["x"][0, -1] == pytest.approx(force / p["k"], rel=1e-3)


def test_generator_conceals_in_the_pneumatic_piston_on_request():
    case = generate_concealed_case(
        "dead_time", 0.2, seed=0, system="pneumatic_piston", n_samples=300
    )
    assert (case.system, case.target) == ("pneumatic_piston", "u")
    assert list(case.data.columns) == ["time", "u", "x", "pa", "pb"]
    assert case.strength == pytest.approx(0.2, rel=0.1)
    with pytest.raises(ModelError, match="not concealed in"):
        generate_concealed_case("coulomb_friction", 0.2, seed=0, system="two_tanks")


@pytest.mark.slow
def test_hidden_air_leak_in_the_pneumatic_piston():
    case = generate_concealed_case(
        "leak", 0.15, seed=2, system="pneumatic_piston", n_samples=700
    )
    assert (case.system, case.target) == ("pneumatic_piston", "pa")
    res = discover_mismatch(
        case.model,
        case.data,
        effects=["leak", "overflow", "sensor_offset"],
        pairs=False,
    )
    assert (res.verdict["effect"], res.verdict["target"]) == ("leak", "pa")
    assert res.verdict["params"]["k"] == pytest.approx(case.params["k"], rel=0.1)
    assert res.fit["rmse_augmented"] < 0.5 * res.fit["rmse_nominal"]


def test_unknown_effect_ids_and_bad_options_are_rejected():
    case = generate_concealed_case("none", 0.2, seed=2, n_samples=200)
    with pytest.raises(ModelError, match="unknown effect ids"):
        discover_mismatch(case.model, case.data, effects=["friction"])
    with pytest.raises(ModelError, match="alpha"):
        discover_mismatch(case.model, case.data, alpha=1.5)


# the real Cascaded Tanks records: tests/models/mismatch/test_tank_effects.py (one run
# checks the overflow, the sensor ceiling, the literature's nominal RMSE and where the
# residual sits)
