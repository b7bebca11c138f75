"""The fits behind ``diagnose_change``: the all-free restart and the intervals.

References: a one-tank plant simulated by scipy's ``solve_ivp`` (not pdmkit's
integrator), and, for the intervals, scipy's ``least_squares`` on the same model
integrated by ``solve_ivp``: its Jacobian gives the textbook covariance
``s^2 (J^T J)^-1`` of white-noise theory.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

MODEL = """
import numpy as np
STATES = {"h": "level"}
INPUTS = {"q": "flow"}
OUTPUTS = ["h"]
PARAMS = {"a": 0.5, "A": 2.0}
FREE = ["a", "A"]
INITIAL = {"h": 0.5}

def rhs(t, x, u, p):
    return {"h": (u["q"] - p["a"] * np.sqrt(np.abs(x["h"]))) / p["A"]}
"""

T = np.arange(400) * 0.5
Q = np.where((T // 40) % 2 == 0, 0.6, 0.2)


def _levels(a, A, h0=0.5):
    def f(t, h):
        q = 0.6 if (t // 40) % 2 == 0 else 0.2
        return [(q - a * np.sqrt(abs(h[0]))) / A]

    return solve_ivp(f, (0, T[-1]), [h0], t_eval=T, max_step=0.25, rtol=1e-10).y[0]


@pytest.fixture(scope="module")
def tank():
    from pdmkit.models.mismatch._recording import make_recording
    from pdmkit.models.ode import load_model_source

    model = load_model_source(MODEL)
    rng = np.random.default_rng(3)
    h = _levels(0.4, 2.0) + rng.normal(0, 0.002, T.size)
    rec = make_recording(model, {"time": T, "q": Q, "h": h}, "data")
    return model, rec, h


def test_an_all_free_fit_stopped_short_is_restarted_from_the_nested_fit(tank):
    from pdmkit.models.mismatch._reference import _fits, _restarted

    model, rec, _ = tank
    far = {"p:a": 0.9, "p:A": 0.6, "x0:h": 0.5}
    # all free, two iterations from far away: stopped short; A held at its true value
    (full,) = _fits(model, rec, [(True, [far])], 2, 2)
    (held,) = _fits(model, rec, [(["a"], [{**far, "p:A": 2.0}])], 60, 2)
    assert held.cost < full.cost  # nested, yet lower: the all-free fit stopped short
    again = _restarted(model, rec, full, [held], 60, 2)
    # the nested fit is a point of the all-free one: restarted there, it ends no higher
    assert again.cost <= held.cost * (1 + 1e-9)
    assert again.values["p:a"] == pytest.approx(0.4, rel=0.02)
    assert again.values["p:A"] == pytest.approx(2.0, rel=0.02)
    # a converged all-free fit is returned as it is
    assert _restarted(model, rec, again, [held], 60, 2) is again


def test_a_held_fit_stopped_short_is_restarted_from_the_points_of_its_space(tank):
    """Holding ``A`` and fitting ``a`` contains the fit of ``a`` alone: never above it."""
    from pdmkit.models.mismatch._reference import _fits, _restarted_helds

    model, rec, _ = tank
    start = {"p:a": 0.5, "p:A": 2.0, "x0:h": 0.5}
    far = {"p:a": 0.9, "p:A": 2.0, "x0:h": 0.5}
    full, alone_a, alone_big_a, held_a = _fits(
        model,
        rec,
        [(True, [start]), (["a"], [start]), (["A"], [start]), (["A"], [start])],
        60,
        2,
    )
    (short,) = _fits(model, rec, [(["a"], [far])], 1, 2)  # A held, stopped short
    assert short.cost > 2 * alone_a.cost
    calls = []

    def fit(specs):
        calls.append(specs)
        return _fits(model, rec, specs, 60, 2)

    reference = {"a": 0.5, "A": 2.0}
    helds = _restarted_helds(
        ["a", "A"], [alone_a, alone_big_a], [held_a, short], full, reference, fit
    )
    # the held fit of A started from a's single fit and from the all-free end with A
    # set back: it ends no higher than a's fit alone, at the true a
    (specs,) = calls
    assert specs[1][0] == ["a"]
    assert {"p:a": alone_a.values["p:a"]}.items() <= specs[1][1][2].items()
    assert specs[1][1][1]["p:A"] == 2.0
    assert helds[1].cost <= alone_a.cost * (1 + 1e-6)
    assert helds[1].values["p:a"] == pytest.approx(0.4, rel=0.02)
    # a converged held fit is kept (nothing lower was found)
    assert helds[0].cost <= held_a.cost


def test_intervals_on_white_noise_are_white_noise_theory(tank):
    """A white residual is worth all its samples: the interval is scipy's own."""
    from pdmkit.models.mismatch._reference import _fits, _interval

    model, rec, h = tank
    (fit,) = _fits(model, rec, [(True, [{"p:a": 0.5, "p:A": 2.0, "x0:h": 0.5}])], 60, 2)

    def resid(theta):
        a, A, h0 = theta
        return _levels(a, A, h0) - h

    ls = least_squares(resid, [0.45, 1.9, 0.5], x_scale=[0.4, 2.0, 0.5])
    J = ls.jac
    s2 = float(ls.fun @ ls.fun) / (T.size - 3)
    # the initial state profiled out, as in pdmkit: the parameters' block of the inverse
    sd_a = float(np.sqrt(np.linalg.inv(J.T @ J)[0, 0] * s2))
    assert fit.values["p:a"] == pytest.approx(ls.x[0], rel=2e-3)
    lo, hi, _ = _interval(fit, "a", fit.values["p:a"])
    half = 0.5 * (hi - lo)
    assert half == pytest.approx(1.959964 * sd_a, rel=0.25)
    assert lo < 0.4 < hi


def test_backlash_on_a_plant_without_a_spring_is_said_to_be_a_position_force():
    """On an axis with no spring (EMPS), the `backlash` term adds kappa clip(q, ±b) to
    the acceleration: no play, a force that depends on position; the sentence says so,
    in N through the force input's gain (1 / m). On a mass-spring-damper it is play."""
    from pdmkit.models.mismatch._candidates import _dummy_scales, attach_candidates
    from pdmkit.models.ode import load_model_source, showcase_model

    axis = load_model_source(
        'import numpy as np\nSTATES = {"q": "position", "v": "velocity"}\n'
        'INPUTS = {"F": "force"}\nOUTPUTS = ["q"]\nPARAMS = {"M": 95.0, "Fv": 200.0}\n'
        'FREE = ["M"]\nINITIAL = {"q": 0.0, "v": 0.0}\n'
        "def rhs(t, x, u, p):\n"
        '    return {"q": x["v"], "v": (u["F"] - p["Fv"] * x["v"]) / p["M"]}\n'
    )
    import dataclasses

    scales = _dummy_scales(axis)
    scales = dataclasses.replace(scales, input_gain={("v", "F"): 1 / 95.0})
    (eff,) = [e for e in attach_candidates(axis, scales, ["backlash"]) if e.target == "v"]
    assert eff.options["spring"] == 0.0 and eff.options["force_input"] == "F"
    text = eff.candidate.explain(eff, {"kappa": 0.957, "b": 0.0379})
    assert "position-dependent force" in text and "play" not in text.split("(")[0]
    assert "±3.45 N" in text  # 0.957 * 0.0379 * 95 kg
    msd = showcase_model("mass_spring_damper")
    scales = dataclasses.replace(_dummy_scales(msd), stiffness={("v", "x"): 4.0})
    (eff,) = [e for e in attach_candidates(msd, scales, ["backlash"]) if e.target == "v"]
    assert eff.options["spring"] == 4.0
    text = eff.candidate.explain(eff, {"kappa": 2.0, "b": 0.1})
    assert text.startswith("Backlash (play)")
