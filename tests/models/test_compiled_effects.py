"""Effects' terms in the compiled loops (models/ode/_compiled_effects.py).

Every effect of the library that acts inside the integration translates; a batch of
every effect a plant admits simulates the same compiled as in numpy (RK4 to rounding,
ROS2 within its error control); a viscous-friction term reproduces the closed-form
response of a damped mass and a Bouc-Wen hysteresis term scipy's ``solve_ivp`` of the
equations written out here; a user's effect whose hook reads its own attributes is left
to numpy, with the same result.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from pdmkit.models.mismatch import fit_model, nominal_scales
from pdmkit.models.mismatch._candidate_base import Candidate, Effect, _lin
from pdmkit.models.mismatch._candidates import _dummy_scales, attach_candidates
from pdmkit.models.mismatch._fit_problem import _lm, _make_jobs, _Problem
from pdmkit.models.mismatch._setup import prepare
from pdmkit.models.mismatch._sparse import SparseTerms, Term
from pdmkit.models.ode import load_model_file, runs_compiled, showcase_model, simulate_ode
from pdmkit.models.ode._compiled_effects import hooks_source, registered

numba = pytest.importorskip(
    "numba", reason="numba is the 'fast' extra (pip install pdmkit[fast])"
)

PLANT = """
import numpy as np

STATES = {"q": "position", "v": "velocity", "h1": "level", "h2": "level"}
INPUTS = {"F": "force", "Qin": "flow"}
OUTPUTS = ["q", "h2"]
PARAMS = {"M": 2.0, "c": 3.0, "k": 40.0, "a": 0.5, "b": 0.4}
FREE = ["c", "a"]
INITIAL = {"q": 0.0, "v": 0.0, "h1": 0.2, "h2": 0.1}

def rhs(t, x, u, p):
    o1 = p["a"] * np.sqrt(np.maximum(x["h1"], 0.0))
    return {
        "q": x["v"],
        "v": (u["F"] - p["c"] * x["v"] - p["k"] * x["q"]) / p["M"],
        "h1": u["Qin"] - o1,
        "h2": o1 - p["b"] * np.sqrt(np.maximum(x["h2"], 0.0)),
    }
"""


@pytest.fixture(autouse=True)
def _compile_at_once(monkeypatch, tmp_path_factory):
    monkeypatch.setenv("PDMKIT_COMPILE", "always")
    monkeypatch.setenv("PDMKIT_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "compiled"))


def test_every_effect_that_acts_inside_the_integration_translates():
    classes = registered()
    src, info, left = hooks_source(classes)
    assert left == {}
    assert set(info) == set(classes) and len(classes) >= 15
    assert "xp." not in src and "eff." not in src and "th[" not in src


class _OwnGain(Candidate):
    """A user's effect whose term reads an attribute of its own."""

    id = "own_gain"
    attach = "velocity"
    param_names = ("a",)
    neutral = MappingProxyType({"a": 0.0})
    gain = 2.0

    def specs(self, eff, sc):
        return {"a": _lin("a", -10.0, 10.0, 1.0)}

    def guesses(self, eff, sc):
        return [{"a": 0.5}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        dx[eff.target] = dx[eff.target] - self.gain * th["a"] * x[eff.target]
        return dx


def test_a_hook_reading_its_own_attributes_is_left_out_with_the_reason():
    _, info, left = hooks_source([_OwnGain])
    assert info == {} and "self.gain" in left["_OwnGain"]


def _plant_batch(tmp_path, method, hold, extra=()):
    """The plant, every effect it admits (one row each, at its first guess), a problem."""
    (tmp_path / "plant.py").write_text(PLANT)
    model = load_model_file(tmp_path / "plant.py").with_integrator(method)
    t = np.arange(300) * 0.02
    force = 20 * np.where(np.floor(t / 1.3) % 2 == 0, 1.0, -1.0)
    inflow = 0.3 + 0.2 * np.sin(0.7 * t)
    sim = simulate_ode(model, t, {"F": force, "Qin": inflow}, n_sub=2)
    data = pd.DataFrame({"time": t, "F": force, "Qin": inflow, **{
        k: sim.outputs[k][0] for k in ("q", "h2")}})  # fmt: skip
    model, s = prepare(model, data, None, data_name="d", validation_name=None,
                       input_hold=hold)  # fmt: skip
    sc = nominal_scales(model, data, fit_model(model, data, max_iter=2), 2)
    jobs = []
    for e in attach_candidates(model, sc, extra=extra):
        start = {f"{e.key}.{k}": v for k, v in e.candidate.guesses(e, sc)[0].items()}
        jobs += _make_jobs(model, (e,), sc, [start], s.values0, s.x_scale, tag=e.key)
    problem = _Problem(model, s.rec, s.n_fit, s.w, 2)
    _lm(problem, jobs, 0)
    return model, problem, [(j, j.values(), j.x0) for j in jobs]


@pytest.mark.parametrize(("method", "hold"), [("rk4", "zoh"), ("ros2", "foh")])
def test_every_effect_simulates_the_same_compiled_as_in_numpy(
    tmp_path, monkeypatch, method, hold
):
    model, problem, rows = _plant_batch(tmp_path, method, hold)
    keys = {r[0].tag for r in rows}
    assert {"hysteresis@v", "input_lag@F", "leak@h1", "overflow@h1->h2"} <= keys
    compiled = problem.simulate(rows)
    assert model.rhs.ran(method, with_effects=True), model.rhs.note
    monkeypatch.setenv("PDMKIT_COMPILE", "never")
    numpy = problem.simulate(rows)
    scale = np.abs(numpy).max(axis=(0, 1))
    gap = np.abs(compiled - numpy).max(axis=1) / scale  # per row and output
    # RK4: the same arithmetic. ROS2: the whole batch halves its step where any row's
    # error estimate passes the tolerance; a last-bit difference can move one such
    # decision, and the two solutions then differ within the method's 1e-3
    assert gap.max() <= (1e-12 if method == "rk4" else 1e-3), gap.max()
    assert np.isfinite(compiled).all()


def test_a_user_effect_left_out_runs_in_numpy_with_the_same_result(tmp_path, monkeypatch):
    model, problem, rows = _plant_batch(tmp_path, "rk4", "zoh", extra=[_OwnGain()])
    own = [r for r in rows if r[0].tag == "own_gain@v"]
    assert len(own) == 1
    assert model.rhs.compiled and not runs_compiled(model, own[0][0].effects)
    compiled = problem.simulate(own)  # in numpy
    monkeypatch.setenv("PDMKIT_COMPILE", "never")
    np.testing.assert_array_equal(compiled, problem.simulate(own))


def _effect_problem(ids, t, force):
    """pdmkit's mass-spring-damper showcase (m = 1, c = 4, k = 400; x measured)."""
    model = showcase_model("mass_spring_damper")
    data = pd.DataFrame({"time": t, "F": force, "x": np.zeros(t.size)})
    model, s = prepare(model, data, None, data_name="d", validation_name=None,
                       input_hold="zoh")  # fmt: skip
    sc = nominal_scales(model, data, fit_model(model, data, max_iter=1), 4)
    effects = attach_candidates(model, sc, ids)
    return model, s, sc, _Problem(model, s.rec, s.n_fit, s.w, 4), effects


def test_viscous_friction_compiled_gives_the_damped_mass_in_closed_form():
    t = np.arange(1000) * 0.001
    model, s, sc, problem, (visc,) = _effect_problem(
        ["viscous_friction"], t, np.full(t.size, 10.0)
    )
    job = _make_jobs(model, (visc,), sc, [{"viscous_friction@v.b": 16.0}], s.values0,
                     s.x_scale)[0]  # fmt: skip
    _lm(problem, [job], 0)
    x = problem.simulate([(job, job.values(), job.x0)])[0, :, 0]
    assert model.rhs.ran("rk4", with_effects=True)
    # m x'' + (c + m b) x' + k x = F: c + m b = 4 + 16 = 20, m = 1, k = 400
    zeta_wn, wd = 10.0, math.sqrt(400.0 - 100.0)
    decay = np.exp(-zeta_wn * t) * (np.cos(wd * t) + zeta_wn / wd * np.sin(wd * t))
    exact = 10.0 / 400.0 * (1.0 - decay)
    np.testing.assert_allclose(x, exact[: x.size], atol=1e-9)  # the fitted samples


def test_hysteresis_compiled_against_the_bouc_wen_equations_in_solve_ivp():
    t = np.arange(1500) * 0.002
    force = 30.0 * np.sin(2 * np.pi * 1.5 * t)
    model, s, sc, problem, effects = _effect_problem(["hysteresis"], t, force)
    (hyst,) = effects
    vals = {"k_h": 200.0, "beta": 30.0, "gamma": -10.0}
    job = _make_jobs(model, (hyst,), sc, [{f"hysteresis@v.{k}": v for k, v in
                     vals.items()}], s.values0, s.x_scale)[0]  # fmt: skip
    _lm(problem, [job], 0)
    x = problem.simulate([(job, job.values(), job.x0)])[0, :, 0]
    assert model.rhs.ran("rk4", with_effects=True)

    def f(tt, y):  # the Bouc-Wen term written out: dv += -k_h (z - x), z' = ...
        xx, vv, z = y
        fk = force[min(int(tt / 0.002 + 1e-9), t.size - 1)]  # held over each sample
        dv = fk - 4.0 * vv - 400.0 * xx - vals["k_h"] * (z - xx)
        dz = vv - vals["beta"] * abs(vv) * z - vals["gamma"] * vv * abs(z)
        return [vv, dv, dz]

    ref = np.empty(t.size)
    y = [0.0, 0.0, 0.0]
    for k in range(t.size):  # sample by sample: the force is a step at each sample
        ref[k] = y[0]
        if k + 1 < t.size:
            sol = solve_ivp(f, (t[k], t[k + 1]), y, rtol=1e-10, atol=1e-12,
                            first_step=1e-4)  # fmt: skip
            y = sol.y[:, -1]
    assert np.abs(x).max() > 0.02  # it moved
    np.testing.assert_allclose(x, ref[: x.size], atol=1e-6 * np.abs(ref).max())


def test_lags_on_the_rig_follow_its_computed_output_compiled(monkeypatch):
    """A sensor lag on LeverPosition (an equation of the states) and the valves' lags."""
    rig = Path(__file__).resolve().parents[2] / "examples" / "pneumatic_rig"
    model = load_model_file(rig / "model_position.py")
    t = np.arange(300) * 0.01
    work = ((t >= 0.2) & (t < 1.6)).astype(float)
    data = pd.DataFrame({"time": t, "outValveHP": 1.0 - work, "outValveWP": work,
                         "LeverPosition": 0.19 * work})  # fmt: skip
    model, s = prepare(model, data, None, data_name="d", validation_name=None,
                       input_hold="zoh")  # fmt: skip
    model = model.with_integrator("rk4")
    sc = _dummy_scales(model)  # magnitudes for the guesses (no fit needed here)
    sc.y_min, sc.y_max, sc.y_std = {"LeverPosition": 0.0}, {"LeverPosition": 0.2}, {
        "LeverPosition": 0.05}  # fmt: skip
    jobs = []
    for e in attach_candidates(model, sc, ["sensor_lag", "input_lag", "hysteresis"]):
        start = {f"{e.key}.{k}": 3 * v for k, v in e.candidate.guesses(e, sc)[0].items()}
        jobs += _make_jobs(model, (e,), sc, [start], s.values0, s.x_scale, tag=e.key)
    problem = _Problem(model, s.rec, s.n_fit, s.w, 8)
    _lm(problem, jobs, 0)
    rows = [(j, j.values(), j.x0) for j in jobs]
    assert "sensor_lag@LeverPosition" in {j.tag for j in jobs}
    assert all(runs_compiled(model, j.effects) for j in jobs)
    compiled = problem.simulate(rows)
    monkeypatch.setenv("PDMKIT_COMPILE", "never")
    numpy = problem.simulate(rows)
    assert np.abs(numpy).max() > 0.1  # the lever went up
    np.testing.assert_allclose(compiled, numpy, rtol=0, atol=1e-12)


def test_sparse_terms_compiled_equal_numpy(tmp_path, monkeypatch):
    model, problem, rows = _plant_batch(tmp_path, "rk4", "zoh")
    labels = ["q**2*v", "sign(v)", "abs(v)*v", "sqrt(h1)", "q**3", "F*h2", "1"]
    terms = [Term.parse(k) for k in labels]
    sparse = SparseTerms(terms, [1.0, 0.5, 2.0, 0.3, 4.0, 0.01, 0.2], {"v": 0.05})
    eff = Effect(sparse, "v")
    start = {f"{eff.key}.c{j}": c for j, c in enumerate([-3, -0.4, -0.2, 0.5, -1, 1, 0.1])}
    s_values = dict(rows[0][1])
    job = _make_jobs(model, (eff,), None, [start], s_values, {}, fit_free=False,
                     x0=rows[0][2])[0]  # fmt: skip
    row = [(job, job.values(), job.x0)]
    assert runs_compiled(model, (eff,))
    compiled = problem.simulate(row)
    monkeypatch.setenv("PDMKIT_COMPILE", "never")
    numpy = problem.simulate(row)
    plain = problem.simulate(rows[-1:])  # a row without the terms
    assert np.abs(numpy - plain).max() > 0.01  # the terms act
    np.testing.assert_allclose(compiled, numpy, rtol=1e-12, atol=1e-14)
