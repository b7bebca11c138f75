"""A constant the model file holds fixed, re-estimated (the ``constant`` candidate).

References are independent of pdmkit's integrator: scipy's ``solve_ivp`` (Radau, tight
tolerances) on the same equations written here.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pdmkit.models.mismatch import discover_mismatch, fit_model
from pdmkit.models.mismatch._candidates import (
    CANDIDATES,
    Effect,
    _dummy_scales,
    attach_candidates,
)
from pdmkit.models.ode import showcase_model
from pdmkit.models.ode._simulate import simulate_ode

CONSTANT = CANDIDATES["constant", "parameter"]


def _tanks_reference(t, u, b, k1, k2, h0=(0.1, 0.1)):
    """Two cascaded Torricelli tanks (the showcase's equations): Radau, inputs held."""

    def f(tt, h, uk):
        q1 = k1 * np.sqrt(abs(h[0]))
        q2 = k2 * np.sqrt(abs(h[1]))
        return [b * uk - q1, q1 - q2]

    h = np.empty((t.size, 2))
    h[0] = h0
    for i in range(t.size - 1):
        sol = solve_ivp(
            f, (t[i], t[i + 1]), h[i], method="Radau", rtol=1e-10, atol=1e-12, args=(u[i],)
        )
        h[i + 1] = sol.y[:, -1]
    return h


def _pump(n, seed=0):
    rng = np.random.default_rng(seed)
    return np.repeat(rng.uniform(2.0, 9.0, n // 25 + 1), 25)[:n]


def test_constants_attach_to_the_fixed_nonzero_parameters_only():
    msd = showcase_model("mass_spring_damper")  # m, c fixed; k free
    keys = [e.key for e in attach_candidates(msd, _dummy_scales(msd), ["constant"])]
    assert keys == ["constant@m", "constant@c"]
    zero_c = msd.with_params(c=0.0)
    assert [
        e.target for e in attach_candidates(zero_c, _dummy_scales(zero_c), ["constant"])
    ] == ["m"]


def test_a_re_estimated_constant_simulates_as_the_file_with_that_value():
    tanks = showcase_model("two_tanks")
    t = np.arange(400) * 1.0
    u = _pump(t.size)
    eff = Effect(CONSTANT, "k2", None, {"nominal": tanks.params["k2"]})
    sim = simulate_ode(
        tanks,
        t,
        {"u": u},
        effects=[eff],
        effect_params={"constant@k2.value": 0.024},
        n_sub=4,
    )
    ref = _tanks_reference(t, u, tanks.params["b"], tanks.params["k1"], 0.024)
    got = np.stack([sim.outputs["h1"][0], sim.outputs["h2"][0]], 1)
    assert np.max(np.abs(got - ref)) < 1e-5 * np.max(np.abs(ref))
    nominal = simulate_ode(tanks, t, {"u": u}, n_sub=4).outputs["h2"][0]
    assert np.max(np.abs(nominal - ref[:, 1])) > 0.05 * np.ptp(ref[:, 1])


def test_a_wrong_constant_is_recovered_by_the_fit():
    tanks = showcase_model("two_tanks")
    t = np.arange(500) * 1.0
    u = _pump(t.size, seed=1)
    true_k1 = 0.0195  # the file says 0.015
    h = _tanks_reference(t, u, tanks.params["b"], true_k1, tanks.params["k2"])
    data = {"time": t, "u": u, "h1": h[:, 0], "h2": h[:, 1]}
    eff = Effect(CONSTANT, "k1", None, {"nominal": tanks.params["k1"]})
    fit = fit_model(tanks, data, effects=[eff], scales=_dummy_scales(tanks), n_sub=4)
    assert fit.values["constant@k1.value"] == pytest.approx(true_k1, rel=1e-3)
    assert fit.values["p:b"] == pytest.approx(tanks.params["b"], rel=1e-3)


@pytest.mark.slow
def test_discovery_points_at_the_wrong_constant_and_prefers_a_named_equivalent():
    tanks = showcase_model("two_tanks")
    t = np.arange(900) * 1.0
    u = _pump(t.size, seed=2)
    rng = np.random.default_rng(3)
    h = _tanks_reference(t, u, tanks.params["b"], 0.0195, tanks.params["k2"])
    h += rng.normal(0.0, 0.002 * np.ptp(h, axis=0), h.shape)
    data = {"time": t, "u": u, "h1": h[:, 0], "h2": h[:, 1]}
    res = discover_mismatch(
        tanks, data, effects=["constant", "leak", "overflow"], pairs=False
    )
    assert (res.verdict["effect"], res.verdict["target"]) == ("constant", "k1")
    assert "0.015" in res.verdict["physics"] and "1.3" in res.verdict["physics"]
    # a leak out of tank 2 and a larger k2 are the same model: the named leak is said
    h = _tanks_reference(t, u, tanks.params["b"], tanks.params["k1"], 0.0195)
    h += rng.normal(0.0, 0.002 * np.ptp(h, axis=0), h.shape)
    data = {"time": t, "u": u, "h1": h[:, 0], "h2": h[:, 1]}
    res = discover_mismatch(tanks, data, effects=["constant", "leak"], pairs=False)
    assert (res.verdict["effect"], res.verdict["target"]) == ("leak", "h2")


def test_the_score_test_ranks_the_wrong_constant_first_and_drops_inactive_ones():
    from pdmkit.models.mismatch._fit_problem import _lm, _make_jobs, _Problem
    from pdmkit.models.mismatch._recording import make_recording
    from pdmkit.models.mismatch._screen_constants import constant_gains
    from pdmkit.models.ode import load_model_source, showcase_source

    source = showcase_source("two_tanks").replace(
        '"k2": 0.015}', '"k2": 0.015, "spare": 3.0}'
    )
    tanks = load_model_source(source, name="tanks_with_a_spare_constant")
    t = np.arange(500) * 1.0
    u = _pump(t.size, seed=4)
    h = _tanks_reference(t, u, tanks.params["b"], 0.0195, tanks.params["k2"])
    rng = np.random.default_rng(5)
    h += rng.normal(0.0, 0.002 * np.ptp(h, axis=0), h.shape)
    rec = make_recording(tanks, {"time": t, "u": u, "h1": h[:, 0], "h2": h[:, 1]})
    values = {f"p:{k}": v for k, v in tanks.params.items()} | {
        f"x0:{s}": v for s, v in tanks.initial.items()
    }
    problem = _Problem(tanks, rec, rec.n, 1.0 / np.std(h, axis=0), 4)
    nominal = _make_jobs(tanks, (), None, [{}], values, {"h1": 0.1, "h2": 0.1})[0]
    _lm(problem, [nominal], 40)
    constants = attach_candidates(tanks, _dummy_scales(tanks), ["constant"])
    assert [e.target for e in constants] == ["k1", "k2", "spare"]
    gain = constant_gains(problem, nominal, constants)
    # one step in k1 removes most of the nominal cost; the spare nothing
    assert gain[0] > gain[1] and gain[0] > 0.5
    assert gain[2] == 0.0


def test_a_concealed_constant_case_changes_a_fixed_constant_of_the_piston():
    from pdmkit.models.mismatch import generate_concealed_case

    case = generate_concealed_case("constant", 0.2, seed=2, n_samples=400)
    assert case.system == "pneumatic_piston" and case.target in ("v_dead", "p_supply")
    nominal = case.model.params[case.target]
    ratio = case.params["value"] / nominal
    assert 0.5 <= ratio <= 2.0 and abs(ratio - 1.0) > 0.01
    assert case.target not in case.model.free
