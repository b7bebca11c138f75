"""Batched RK4 simulation of user ODE models and of candidate effects.

References: scipy.integrate.solve_ivp (DOP853, rtol 1e-11) integrated interval by
interval with the input held; hand-written models in which the effect is spelled out.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pdmkit.errors import ModelError
from pdmkit.models.mismatch._candidates import (
    CANDIDATES,
    Effect,
    _dummy_scales,
    attach_candidates,
)
from pdmkit.models.ode import showcase_model
from pdmkit.models.ode._modelfile import OdeModel
from pdmkit.models.ode._simulate import simulate_ode


def zoh_reference(f, y0, t, u):
    """solve_ivp over each sample interval with the input held (tight tolerances)."""
    y = np.asarray(y0, dtype=float)
    out = [y]
    for k in range(t.size - 1):
        sol = solve_ivp(
            f, (t[k], t[k + 1]), y, args=(u[k],), method="DOP853", rtol=1e-11, atol=1e-13
        )
        y = sol.y[:, -1]
        out.append(y)
    return np.array(out)


@pytest.fixture
def steps(rng):
    t = np.arange(300) * 0.02
    F = np.repeat(rng.uniform(-40, 40, 30), 10)
    return t, F


def test_rk4_matches_solve_ivp_linear(steps):
    t, F = steps
    msd = showcase_model("mass_spring_damper")
    ref = zoh_reference(
        lambda tt, y, f: [y[1], f - 4.0 * y[1] - 400.0 * y[0]], [0.0, 0.0], t, F
    )
    errs = []
    for n_sub in (2, 4, 8, 16):
        r = simulate_ode(msd, t, {"F": F}, n_sub=n_sub)
        errs.append(np.max(np.abs(r.states["x"][0] - ref[:, 0])))
    scale = np.max(np.abs(ref[:, 0]))
    assert errs[-1] < 1e-7 * scale
    # fourth order: halving the step divides the error by about 16
    assert 10 < errs[0] / errs[1] < 22 and 10 < errs[1] / errs[2] < 22


def test_rk4_matches_solve_ivp_nonlinear_tanks(rng):
    tanks = showcase_model("cascaded_tanks")
    t = np.arange(200) * 4.0
    u = np.repeat(rng.uniform(1, 6, 20), 10)
    p = tanks.params
    ref = zoh_reference(
        lambda tt, y, uk: [
            uk - p["k1"] * abs(y[0]) ** 0.5,
            p["k2"] * abs(y[0]) ** 0.5 - p["k3"] * abs(y[1]) ** 0.5,
        ],
        [150.0, 5.0],
        t,
        u,
    )
    r = simulate_ode(tanks, t, {"u": u}, n_sub=8)
    np.testing.assert_allclose(r.states["h1"][0], ref[:, 0], rtol=1e-8)
    np.testing.assert_allclose(r.outputs["h2"][0], ref[:, 1], rtol=1e-8)


def test_batch_rows_equal_single_runs(steps):
    t, F = steps
    msd = showcase_model("mass_spring_damper")
    ks = np.array([300.0, 400.0, 500.0])
    x0 = np.array([0.0, 0.01, -0.02])
    batch = simulate_ode(msd, t, {"F": F}, params={"k": ks}, x0={"x": x0})
    assert batch.outputs["x"].shape == (3, t.size)
    for i in range(3):
        one = simulate_ode(
            msd, t, {"F": F}, params={"k": float(ks[i])}, x0={"x": float(x0[i])}
        )
        np.testing.assert_array_equal(batch.outputs["x"][i], one.outputs["x"][0])


@pytest.mark.torch
def test_torch_path_matches_numpy_and_gradient_matches_finite_difference(steps):
    torch = pytest.importorskip("torch")
    t, F = steps[0][:80], steps[1][:80]
    msd = showcase_model("mass_spring_damper")
    k = torch.tensor(380.0, dtype=torch.float64, requires_grad=True)
    r = simulate_ode(msd, t, {"F": F}, params={"k": k}, n_sub=2)
    loss = (r.outputs["x"] ** 2).sum()
    loss.backward()
    ref = simulate_ode(msd, t, {"F": F}, params={"k": 380.0}, n_sub=2).outputs["x"]
    np.testing.assert_allclose(r.outputs["x"].detach().numpy(), ref, rtol=1e-12)

    def j(kv):
        y = simulate_ode(msd, t, {"F": F}, params={"k": kv}, n_sub=2).outputs["x"]
        return float((y**2).sum())

    fd = (j(380.0 + 1e-3) - j(380.0 - 1e-3)) / 2e-3
    assert float(k.grad) == pytest.approx(fd, rel=1e-6)


def test_effect_terms_match_hand_written_models(steps):
    """Coulomb friction and cubic stiffness added by the library == written in the rhs."""
    t, F = steps
    msd = showcase_model("mass_spring_damper")
    sc = _dummy_scales(msd)
    effs = {e.key: e for e in attach_candidates(msd, sc)}
    coul, cub = effs["coulomb_friction@v"], effs["cubic_stiffness@v"]
    eps = coul.opt("eps")
    a, k3 = 2.0, 3000.0
    h = 0.02 / 4
    eps_eff = np.sqrt(eps**2 + (0.5 * a * h) ** 2)

    def rhs(tt, x, u, p):
        v = x["v"]
        return {
            "x": v,
            "v": (u["F"] - 4.0 * v - 400.0 * x["x"])
            - a * np.tanh(v / eps_eff)
            - k3 * x["x"] ** 3,
        }

    hand = OdeModel(msd.states, msd.inputs, msd.outputs, msd.params, rhs)
    ref = simulate_ode(hand, t, {"F": F}, n_sub=4).outputs["x"][0]
    got = simulate_ode(
        msd,
        t,
        {"F": F},
        effects=[coul, cub],
        n_sub=4,
        effect_params={"coulomb_friction@v.a": a, "cubic_stiffness@v.k3": k3},
    ).outputs["x"][0]
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-15)


def test_input_and_sensor_effects_against_references(steps):
    t, F = steps
    msd = showcase_model("mass_spring_damper")
    sc = _dummy_scales(msd)
    base = simulate_ode(msd, t, {"F": F}).outputs["x"][0]
    # dead time of exactly 3 samples == the input shifted by 3 samples
    dt_eff = Effect(CANDIDATES["dead_time", "input"], "F")
    got = simulate_ode(
        msd, t, {"F": F}, effects=[dt_eff], effect_params={"dead_time@F.tau": 3 * 0.02}
    ).outputs["x"][0]
    shifted = np.r_[np.full(3, F[0]), F[:-3]]
    ref = simulate_ode(msd, t, {"F": shifted}).outputs["x"][0]
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-14)
    # sensor offset and gain act on the output only
    off = Effect(CANDIDATES["sensor_offset", "output"], "x")
    gain = Effect(CANDIDATES["sensor_gain", "output"], "x")
    got = simulate_ode(
        msd,
        t,
        {"F": F},
        effects=[gain, off],
        effect_params={"sensor_gain@x.gain": 1.5, "sensor_offset@x.offset": 0.2},
    )
    np.testing.assert_allclose(got.outputs["x"][0], 1.5 * base + 0.2, rtol=1e-12)
    np.testing.assert_allclose(got.states["x"][0], base, rtol=1e-12)
    # input saturation: never passes more than s
    sat = next(e for e in attach_candidates(msd, sc, ["saturation"]))
    clipped = simulate_ode(
        msd, t, {"F": F}, effects=[sat], effect_params={"saturation@F.s": 10.0}
    ).outputs["x"][0]
    hard = simulate_ode(msd, t, {"F": np.clip(F, -10, 10)}).outputs["x"][0]
    assert np.max(np.abs(clipped - hard)) < 0.02 * np.max(np.abs(hard))


def test_input_lag_and_sensor_lag_match_explicit_lag_states(rng):
    """First-order lags added as extra states == the lag written into a model by hand."""
    tanks = showcase_model("two_tanks")
    t = np.arange(300) * 2.0
    u = np.repeat(rng.uniform(0.5, 6, 30), 10)
    tau_u, tau_y = 15.0, 25.0
    p = tanks.params

    def f(tt, y, uk):
        h1, h2, z, s = y
        q1 = p["k1"] * abs(h1) ** 0.5
        return [
            p["b"] * z - q1,
            q1 - p["k2"] * abs(h2) ** 0.5,
            (uk - z) / tau_u,
            (h2 - s) / tau_y,
        ]

    ref = zoh_reference(f, [0.1, 0.1, u[0], 0.1], t, u)
    lag = Effect(CANDIDATES["input_lag", "input"], "u")
    slag = Effect(CANDIDATES["sensor_lag", "output"], "h2")
    r = simulate_ode(
        tanks,
        t,
        {"u": u},
        effects=[lag, slag],
        n_sub=8,
        effect_params={"input_lag@u.tau": tau_u, "sensor_lag@h2.tau": tau_y},
    )
    np.testing.assert_allclose(r.outputs["h1"][0], ref[:, 0], rtol=1e-7)
    np.testing.assert_allclose(r.outputs["h2"][0], ref[:, 3], rtol=1e-7)


def test_overflow_caps_the_level_and_routes_the_excess(rng):
    tanks = showcase_model("two_tanks")
    sc = _dummy_scales(tanks)
    t = np.arange(400) * 2.0
    u = np.full(400, 6.0)  # steady state h1 = (0.012 / 0.015)^2 = 0.64 without overflow
    of = next(
        e
        for e in attach_candidates(tanks, sc, ["overflow"])
        if e.partner == "h2" and e.target == "h1"
    )
    of = Effect(of.candidate, of.target, of.partner, {"w": 1e-3, "wf": 1e-6})
    r = simulate_ode(
        tanks,
        t,
        {"u": u},
        effects=[of],
        n_sub=4,
        effect_params={"overflow@h1->h2.cap": 0.3, "overflow@h1->h2.into": 1.0},
    )
    h1 = r.states["h1"][0]
    assert h1.max() < 0.3 + 0.01 and h1[-1] > 0.29
    # all spilled water goes to tank 2: at steady state its outflow equals the pump flow
    h2 = r.states["h2"][0]
    assert 0.015 * np.sqrt(h2[-1]) == pytest.approx(0.002 * 6.0, rel=1e-3)


def test_bad_arguments_are_rejected(steps):
    t, F = steps
    msd = showcase_model("mass_spring_damper")
    with pytest.raises(ModelError, match="uniformly spaced"):
        simulate_ode(msd, np.r_[t[:10], t[11:]], {"F": F[:-1]})
    with pytest.raises(ModelError, match="missing"):
        simulate_ode(msd, t, {})
    with pytest.raises(ModelError, match="unknown parameters"):
        simulate_ode(msd, t, {"F": F}, params={"mass": 1.0})
    with pytest.raises(ModelError, match="n_sub"):
        simulate_ode(msd, t, {"F": F}, n_sub=0)
